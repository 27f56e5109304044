//! Images, planned first and made once every pass has said how it uses them.
//!
//! An image's usage flags are not chosen where it is made: each pass that binds it declares
//! its use ([`super::uses::Use`]), and the image is made with the union of them.
//!
//! ```text
//!   Image::planned(desc)          each pass's `new`                      Gpu::make_planned()
//!   usage = its maker's own  ──►  uses::writes(&[Use::Sampled(img),…])  ──►  vkCreateImage(usage),
//!   (attachment, copies)          usage |= SAMPLED, STORAGE, …              its views, then the
//!                                 (the descriptor write waits)              waiting descriptor writes
//! ```
//!
//! A planned image's `desc.usage` holds only what its maker does with it outside descriptor
//! sets: draws into it (attachments) or copies to or from it. [`Image::require`] adds a use
//! declared elsewhere (the translucent pass drawing over the frame's radiance). Once made, an
//! image's usage is fixed: a use declared after that panics, naming the image and the use.
//! [`Image::new`] makes an image at once with the usage its caller gives (textures).

use super::device::{Gpu, PlannedImage, Retired};
use super::error::{vk_err, GpuError, GpuResult};
use super::tracker::Resting;
use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, OnceLock, Weak};

/// What kind of view an image gets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewKind {
    D2,
    D2Array,
    Cube,
}

/// How to create an [`Image`].
#[derive(Clone, Debug)]
pub struct ImageDesc<'a> {
    pub name: &'a str,
    pub format: vk::Format,
    pub width: u32,
    pub height: u32,
    pub layers: u32,
    /// For [`Image::planned`]: what its maker does with it outside descriptor sets (attachment,
    /// copies); the passes' declared uses add theirs. For [`Image::new`]: all of its usage.
    pub usage: vk::ImageUsageFlags,
    pub view: ViewKind,
}

/// A 2D image (or array) with a full view and one view per layer.
pub struct Image {
    cell: Arc<ImageCell>,
    pub format: vk::Format,
    pub width: u32,
    pub height: u32,
    pub layers: u32,
    pub name: String,
    /// The state the last submitted recording left it in (`tracker.rs`).
    pub(super) resting: Arc<Resting>,
}

/// What an image is before and after it is made; shared (weakly) with the [`Gpu`]'s list of
/// planned images and the descriptor writes waiting for it (`planned.rs`).
pub(super) struct ImageCell {
    gpu: Arc<Gpu>,
    name: String,
    format: vk::Format,
    extent: (u32, u32),
    layers: u32,
    view: ViewKind,
    /// The usage so far (`vk::ImageUsageFlags` bits); fixed once `made` is set.
    usage: AtomicU32,
    made: OnceLock<Made>,
}

/// The Vulkan objects of a made image.
pub(super) struct Made {
    raw: vk::Image,
    allocation: Allocation,
    pub(super) view: vk::ImageView,
    layer_views: Vec<vk::ImageView>,
}

pub(super) fn aspect_of(format: vk::Format) -> vk::ImageAspectFlags {
    match format {
        vk::Format::D32_SFLOAT | vk::Format::D16_UNORM | vk::Format::X8_D24_UNORM_PACK32 => {
            vk::ImageAspectFlags::DEPTH
        }
        _ => vk::ImageAspectFlags::COLOR,
    }
}

impl Image {
    /// Makes the image now, with `desc.usage` as all of its usage.
    pub fn new(gpu: &Arc<Gpu>, desc: &ImageDesc) -> GpuResult<Image> {
        let image = Self::unmade(gpu, desc);
        image.cell.make()?;
        Ok(image)
    }

    /// Plans the image: it is made by the next [`Gpu::make_planned`], with `desc.usage` and
    /// every use the passes declare before that.
    pub fn planned(gpu: &Arc<Gpu>, desc: &ImageDesc) -> Image {
        let image = Self::unmade(gpu, desc);
        let cell: Arc<dyn PlannedImage> = image.cell.clone();
        gpu.plan_image(&cell);
        image
    }

    fn unmade(gpu: &Arc<Gpu>, desc: &ImageDesc) -> Image {
        let (width, height, layers) = (desc.width.max(1), desc.height.max(1), desc.layers.max(1));
        Image {
            cell: Arc::new(ImageCell {
                gpu: gpu.clone(),
                name: desc.name.into(),
                format: desc.format,
                extent: (width, height),
                layers,
                view: desc.view,
                usage: AtomicU32::new(desc.usage.as_raw()),
                made: OnceLock::new(),
            }),
            format: desc.format,
            width,
            height,
            layers,
            name: desc.name.into(),
            resting: Resting::new(desc.name),
        }
    }

    /// What it is (or will be) made for: sampled, storage, attachment, transfer.
    pub fn usage(&self) -> vk::ImageUsageFlags {
        self.cell.usage()
    }

    /// Declares a use of the image: added to its usage while it is planned, checked once it
    /// is made. Declared on the thread that plans the image and calls
    /// [`Gpu::make_planned`] (a renderer's construction).
    ///
    /// # Panics
    /// When the image is made without `usage`: the use was declared too late (after
    /// [`Gpu::make_planned`]), a programming error the validation layer would otherwise
    /// report later, further from its cause.
    pub fn require(&self, usage: vk::ImageUsageFlags, what: impl std::fmt::Display) {
        if self.is_made() {
            assert!(
                self.usage().contains(usage),
                "{} is used as {what} but was made without {usage:?}: its use was declared \
                 after Gpu::make_planned made it",
                self.name
            );
        } else {
            self.cell.usage.fetch_or(usage.as_raw(), Ordering::Relaxed);
        }
    }

    /// Checks that the image, made, has `usage` (a command's use of it: `Cmd::barriers`).
    ///
    /// # Panics
    /// When it is not made yet, or was made without `usage`.
    pub(super) fn expect_usage(&self, usage: vk::ImageUsageFlags, what: impl std::fmt::Display) {
        self.cell.made();
        self.require(usage, what);
    }

    /// Whether its Vulkan objects exist yet.
    pub fn is_made(&self) -> bool {
        self.cell.made.get().is_some()
    }

    /// Whether `other` is this image.
    pub(super) fn is(&self, other: &Image) -> bool {
        Arc::ptr_eq(&self.cell, &other.cell)
    }

    /// The image as the device's list of waiting writes holds it.
    pub(super) fn planned_ref(&self) -> Weak<dyn PlannedImage> {
        let cell: Arc<dyn PlannedImage> = self.cell.clone();
        Arc::downgrade(&cell)
    }

    pub(super) fn raw(&self) -> vk::Image {
        self.cell.made().raw
    }

    pub(super) fn view(&self) -> vk::ImageView {
        self.cell.made().view
    }

    /// The view of one layer (the whole image when it has one layer).
    pub(super) fn layer_view(&self, layer: u32) -> vk::ImageView {
        let made = self.cell.made();
        made.layer_views
            .get(layer as usize)
            .copied()
            .unwrap_or(made.view)
    }

    pub(super) fn aspect(&self) -> vk::ImageAspectFlags {
        aspect_of(self.format)
    }

    pub fn extent(&self) -> vk::Extent2D {
        vk::Extent2D {
            width: self.width,
            height: self.height,
        }
    }
}

impl ImageCell {
    pub(super) fn usage(&self) -> vk::ImageUsageFlags {
        vk::ImageUsageFlags::from_raw(self.usage.load(Ordering::Relaxed))
    }

    /// Its Vulkan objects.
    ///
    /// # Panics
    /// When it is not made yet: a planned image is used before [`Gpu::make_planned`].
    pub(super) fn made(&self) -> &Made {
        self.made.get().unwrap_or_else(|| {
            panic!(
                "{} is used before it is made: Gpu::make_planned makes the planned images once \
                 every pass has declared its uses",
                self.name
            )
        })
    }

    pub(super) fn is_made(&self) -> bool {
        self.made.get().is_some()
    }

    /// Makes the image, its memory and views with the usage declared so far (nothing if it is
    /// made already).
    pub(super) fn make(&self) -> GpuResult<()> {
        if self.is_made() {
            return Ok(());
        }
        let usage = self.usage();
        if usage.is_empty() {
            return Err(GpuError::UnusedImage(self.name.clone()));
        }
        let gpu = &self.gpu;
        let name = self.name.as_str();
        let mut flags = vk::ImageCreateFlags::empty();
        if self.view == ViewKind::Cube {
            flags |= vk::ImageCreateFlags::CUBE_COMPATIBLE;
        }
        let info = vk::ImageCreateInfo::default()
            .flags(flags)
            .image_type(vk::ImageType::TYPE_2D)
            .format(self.format)
            .extent(vk::Extent3D {
                width: self.extent.0,
                height: self.extent.1,
                depth: 1,
            })
            .mip_levels(1)
            .array_layers(self.layers)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        let device = gpu.raw();
        // SAFETY: the device is live and `info` is valid (1 mip, ≥1 layer, non-zero extent,
        // non-empty usage).
        let raw = unsafe { device.create_image(&info, None) }.map_err(vk_err("vkCreateImage"))?;
        // SAFETY: raw is an image of this device.
        let requirements = unsafe { device.get_image_memory_requirements(raw) };
        let allocation = gpu
            .allocator()
            .allocate(&AllocationCreateDesc {
                name,
                requirements,
                location: MemoryLocation::GpuOnly,
                linear: false,
                allocation_scheme: AllocationScheme::GpuAllocatorManaged,
            })
            .map_err(|source| {
                // SAFETY: raw is unused and owned here.
                unsafe { device.destroy_image(raw, None) };
                GpuError::Allocation {
                    name: name.into(),
                    source,
                }
            })?;
        // SAFETY: the allocation was made for this image's requirements and is not bound yet.
        if let Err(e) =
            unsafe { device.bind_image_memory(raw, allocation.memory(), allocation.offset()) }
        {
            let _ = gpu.allocator().free(allocation);
            // SAFETY: raw is unused and owned here.
            unsafe { device.destroy_image(raw, None) };
            return Err(vk_err("vkBindImageMemory")(e));
        }
        gpu.set_name(raw, name);
        // From here on the objects are in `made`, which retires whatever was made so far if a
        // view fails below.
        let mut made = Made {
            raw,
            allocation,
            view: vk::ImageView::null(),
            layer_views: Vec::new(),
        };
        let aspect = aspect_of(self.format);
        let make_view = |ty: vk::ImageViewType, base: u32, count: u32| {
            let info = vk::ImageViewCreateInfo::default()
                .image(raw)
                .view_type(ty)
                .format(self.format)
                .subresource_range(vk::ImageSubresourceRange {
                    aspect_mask: aspect,
                    base_mip_level: 0,
                    level_count: 1,
                    base_array_layer: base,
                    layer_count: count,
                });
            // SAFETY: raw is a live image with memory bound; the range lies inside it.
            unsafe { device.create_image_view(&info, None) }.map_err(vk_err("vkCreateImageView"))
        };
        let full_type = match self.view {
            ViewKind::D2 => vk::ImageViewType::TYPE_2D,
            ViewKind::D2Array => vk::ImageViewType::TYPE_2D_ARRAY,
            ViewKind::Cube => vk::ImageViewType::CUBE,
        };
        let views = (|| {
            made.view = make_view(full_type, 0, self.layers)?;
            gpu.set_name(made.view, &format!("{name}.view"));
            if self.layers > 1 {
                for l in 0..self.layers {
                    let v = make_view(vk::ImageViewType::TYPE_2D, l, 1)?;
                    gpu.set_name(v, &format!("{name}.layer[{l}]"));
                    made.layer_views.push(v);
                }
            }
            Ok(())
        })();
        if let Err(e) = views {
            self.retire(made);
            return Err(e);
        }
        if let Err(made) = self.made.set(made) {
            // Made by another thread meanwhile: this copy was never used.
            self.retire(made);
        }
        Ok(())
    }

    fn retire(&self, made: Made) {
        let mut views = made.layer_views;
        if made.view != vk::ImageView::null() {
            views.push(made.view);
        }
        self.gpu
            .retire(Retired::Image(made.raw, made.allocation, views));
    }
}

impl PlannedImage for ImageCell {
    fn make(&self) -> GpuResult<()> {
        ImageCell::make(self)
    }

    fn made_view(&self) -> Option<vk::ImageView> {
        self.made.get().map(|m| m.view)
    }
}

impl Drop for ImageCell {
    fn drop(&mut self) {
        if let Some(made) = self.made.take() {
            self.retire(made);
        }
    }
}
