//! RAII buffers, images and samplers on gpu-allocator, each with a debug name and its state at
//! rest for the barrier tracker (`tracker.rs`: barriers are derived, not written by hand). Dropping one retires it
//! to the graveyard of [`Gpu`]; it is destroyed once the GPU can no longer be using it.

use super::device::{Gpu, Retired};
use super::error::{vk_err, GpuError, GpuResult};
use super::tracker::Resting;
use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
pub use gpu_allocator::MemoryLocation;
use std::sync::Arc;

/// A buffer and its memory.
pub struct Buffer {
    gpu: Arc<Gpu>,
    pub(super) raw: vk::Buffer,
    allocation: Option<Allocation>,
    pub size: u64,
    pub name: String,
    /// The state the last submitted recording left it in (`tracker.rs`).
    pub(super) resting: Arc<Resting>,
}

impl Buffer {
    /// Creates a buffer of `size` bytes (at least 4) in `location`.
    pub fn new(
        gpu: &Arc<Gpu>,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> GpuResult<Buffer> {
        let size = size.max(4);
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        let device = gpu.raw();
        // SAFETY: the device is live and `info` is a valid create info.
        let raw = unsafe { device.create_buffer(&info, None) }.map_err(vk_err("vkCreateBuffer"))?;
        // SAFETY: raw is a buffer of this device.
        let requirements = unsafe { device.get_buffer_memory_requirements(raw) };
        let allocation = gpu
            .allocator()
            .allocate(&AllocationCreateDesc {
                name,
                requirements,
                location,
                linear: true,
                allocation_scheme: AllocationScheme::GpuAllocatorManaged,
            })
            .map_err(|source| {
                // SAFETY: raw is unused and owned here.
                unsafe { device.destroy_buffer(raw, None) };
                GpuError::Allocation {
                    name: name.into(),
                    source,
                }
            })?;
        // SAFETY: the allocation was made for this buffer's requirements and is not bound yet.
        if let Err(e) =
            unsafe { device.bind_buffer_memory(raw, allocation.memory(), allocation.offset()) }
        {
            let _ = gpu.allocator().free(allocation);
            // SAFETY: raw is unused and owned here.
            unsafe { device.destroy_buffer(raw, None) };
            return Err(vk_err("vkBindBufferMemory")(e));
        }
        gpu.set_name(raw, name);
        Ok(Buffer {
            gpu: gpu.clone(),
            raw,
            allocation: Some(allocation),
            size,
            name: name.into(),
            resting: Resting::new(name),
        })
    }

    /// A device-local buffer of per-frame constants (uniform or storage), written from the
    /// command stream by [`Cmd::update_buffer`](super::Cmd::update_buffer).
    pub fn constants(
        gpu: &Arc<Gpu>,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
    ) -> GpuResult<Buffer> {
        Self::new(
            gpu,
            name,
            size.next_multiple_of(4),
            usage | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )
    }

    /// Copies `bytes` into a host-visible buffer at `offset`. The caller makes sure the GPU is
    /// not using the range (timeline waits); memory is coherent (gpu-allocator only hands out
    /// host-coherent memory for host-visible locations), so no flush is needed.
    pub fn write(&self, offset: u64, bytes: &[u8]) -> anyhow::Result<()> {
        let ptr = self.mapped_ptr()?;
        anyhow::ensure!(
            offset + bytes.len() as u64 <= self.size,
            "write of {} bytes at {offset} overflows buffer {} ({} bytes)",
            bytes.len(),
            self.name,
            self.size
        );
        // SAFETY: the mapping covers `size` bytes, the range was checked above, and `bytes`
        // cannot overlap GPU-mapped memory.
        unsafe {
            std::ptr::copy_nonoverlapping(bytes.as_ptr(), ptr.add(offset as usize), bytes.len())
        };
        Ok(())
    }

    /// Reads the whole host-visible buffer. The caller has waited for the GPU writes.
    pub fn read(&self) -> anyhow::Result<Vec<u8>> {
        let ptr = self.mapped_ptr()?;
        let mut out = vec![0u8; self.size as usize];
        // SAFETY: the mapping covers `size` bytes and stays mapped while self is alive.
        unsafe { std::ptr::copy_nonoverlapping(ptr, out.as_mut_ptr(), out.len()) };
        Ok(out)
    }

    /// Reads `out.len()` bytes at `offset` of the host-visible buffer into `out`. The caller has
    /// waited for the GPU writes.
    pub fn read_into(&self, offset: u64, out: &mut [u8]) -> anyhow::Result<()> {
        let ptr = self.mapped_ptr()?;
        anyhow::ensure!(
            offset + out.len() as u64 <= self.size,
            "read of {} bytes at {offset} overflows buffer {} ({} bytes)",
            out.len(),
            self.name,
            self.size
        );
        // SAFETY: the mapping covers `size` bytes, the range was checked above, and `out`
        // cannot overlap GPU-mapped memory.
        unsafe {
            std::ptr::copy_nonoverlapping(ptr.add(offset as usize), out.as_mut_ptr(), out.len())
        };
        Ok(())
    }

    fn mapped_ptr(&self) -> anyhow::Result<*mut u8> {
        self.allocation
            .as_ref()
            .and_then(Allocation::mapped_ptr)
            .map(|p| p.as_ptr().cast::<u8>())
            .ok_or_else(|| anyhow::anyhow!("buffer {} is not host-visible", self.name))
    }

    pub fn raw(&self) -> vk::Buffer {
        self.raw
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        if let Some(a) = self.allocation.take() {
            self.gpu.retire(Retired::Buffer(self.raw, a));
        }
    }
}

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
    pub usage: vk::ImageUsageFlags,
    pub view: ViewKind,
}

/// A 2D image (or array) with a full view and one view per layer.
pub struct Image {
    gpu: Arc<Gpu>,
    pub(super) raw: vk::Image,
    allocation: Option<Allocation>,
    pub(super) view: vk::ImageView,
    pub(super) layer_views: Vec<vk::ImageView>,
    pub format: vk::Format,
    pub width: u32,
    pub height: u32,
    pub layers: u32,
    /// What it was made for (sampled, storage, attachment, transfer).
    pub usage: vk::ImageUsageFlags,
    pub name: String,
    /// The state the last submitted recording left it in (`tracker.rs`).
    pub(super) resting: Arc<Resting>,
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
    pub fn new(gpu: &Arc<Gpu>, desc: &ImageDesc) -> GpuResult<Image> {
        let mut flags = vk::ImageCreateFlags::empty();
        if desc.view == ViewKind::Cube {
            flags |= vk::ImageCreateFlags::CUBE_COMPATIBLE;
        }
        let info = vk::ImageCreateInfo::default()
            .flags(flags)
            .image_type(vk::ImageType::TYPE_2D)
            .format(desc.format)
            .extent(vk::Extent3D {
                width: desc.width.max(1),
                height: desc.height.max(1),
                depth: 1,
            })
            .mip_levels(1)
            .array_layers(desc.layers.max(1))
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(desc.usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        let device = gpu.raw();
        // SAFETY: the device is live and `info` is valid (1 mip, ≥1 layer, non-zero extent).
        let raw = unsafe { device.create_image(&info, None) }.map_err(vk_err("vkCreateImage"))?;
        // SAFETY: raw is an image of this device.
        let requirements = unsafe { device.get_image_memory_requirements(raw) };
        let allocation = gpu
            .allocator()
            .allocate(&AllocationCreateDesc {
                name: desc.name,
                requirements,
                location: MemoryLocation::GpuOnly,
                linear: false,
                allocation_scheme: AllocationScheme::GpuAllocatorManaged,
            })
            .map_err(|source| {
                // SAFETY: raw is unused and owned here.
                unsafe { device.destroy_image(raw, None) };
                GpuError::Allocation {
                    name: desc.name.into(),
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
        gpu.set_name(raw, desc.name);
        // From here on the image is owned by `image`, whose Drop retires it with its views, so
        // a failed view creation below cleans up everything made so far.
        let mut image = Image {
            gpu: gpu.clone(),
            raw,
            allocation: Some(allocation),
            view: vk::ImageView::null(),
            layer_views: Vec::new(),
            format: desc.format,
            width: desc.width.max(1),
            height: desc.height.max(1),
            layers: desc.layers.max(1),
            usage: desc.usage,
            name: desc.name.into(),
            resting: Resting::new(desc.name),
        };

        let aspect = aspect_of(desc.format);
        let layers = desc.layers.max(1);
        let make_view = |ty: vk::ImageViewType, base: u32, count: u32| {
            let info = vk::ImageViewCreateInfo::default()
                .image(raw)
                .view_type(ty)
                .format(desc.format)
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
        let full_type = match desc.view {
            ViewKind::D2 => vk::ImageViewType::TYPE_2D,
            ViewKind::D2Array => vk::ImageViewType::TYPE_2D_ARRAY,
            ViewKind::Cube => vk::ImageViewType::CUBE,
        };
        image.view = make_view(full_type, 0, layers)?;
        gpu.set_name(image.view, &format!("{}.view", desc.name));
        if layers > 1 {
            for l in 0..layers {
                let v = make_view(vk::ImageViewType::TYPE_2D, l, 1)?;
                gpu.set_name(v, &format!("{}.layer[{l}]", desc.name));
                image.layer_views.push(v);
            }
        }
        Ok(image)
    }

    /// The view of one layer (the whole image when it has one layer).
    pub(super) fn layer_view(&self, layer: u32) -> vk::ImageView {
        self.layer_views
            .get(layer as usize)
            .copied()
            .unwrap_or(self.view)
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

impl Drop for Image {
    fn drop(&mut self) {
        if let Some(a) = self.allocation.take() {
            let mut views = std::mem::take(&mut self.layer_views);
            if self.view != vk::ImageView::null() {
                views.push(self.view);
            }
            self.gpu.retire(Retired::Image(self.raw, a, views));
        }
    }
}

/// Texture filtering.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    Nearest,
    Linear,
    /// Linear filtering with depth comparison (`sampler2DArrayShadow`): hardware PCF.
    LinearCompare,
}

/// A sampler.
pub struct Sampler {
    gpu: Arc<Gpu>,
    pub(super) raw: vk::Sampler,
}

impl Sampler {
    pub fn new(gpu: &Arc<Gpu>, name: &str, filter: Filter, repeat: bool) -> GpuResult<Sampler> {
        let f = match filter {
            Filter::Nearest => vk::Filter::NEAREST,
            _ => vk::Filter::LINEAR,
        };
        let mode = if repeat {
            vk::SamplerAddressMode::REPEAT
        } else {
            vk::SamplerAddressMode::CLAMP_TO_EDGE
        };
        let mut info = vk::SamplerCreateInfo::default()
            .mag_filter(f)
            .min_filter(f)
            .mipmap_mode(vk::SamplerMipmapMode::NEAREST)
            .address_mode_u(mode)
            .address_mode_v(mode)
            .address_mode_w(mode)
            .max_lod(0.0);
        if filter == Filter::LinearCompare {
            // Shadow maps have reversed depth (`plan/lighting.rs`): a point is lit where its depth
            // is at least the stored one, and beyond the map's border (depth 0, the far end).
            info = info
                .compare_enable(true)
                .compare_op(vk::CompareOp::GREATER_OR_EQUAL)
                .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_BORDER)
                .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_BORDER)
                .border_color(vk::BorderColor::FLOAT_TRANSPARENT_BLACK);
        }
        // SAFETY: the device is live and `info` is valid.
        let raw =
            unsafe { gpu.raw().create_sampler(&info, None) }.map_err(vk_err("vkCreateSampler"))?;
        gpu.set_name(raw, name);
        Ok(Sampler {
            gpu: gpu.clone(),
            raw,
        })
    }
}

impl Drop for Sampler {
    fn drop(&mut self) {
        self.gpu.retire(Retired::Sampler(self.raw));
    }
}
