//! What a pass uses, declared once.
//!
//! A pass lists its resources in the order its shader declares their bindings, each with how
//! it uses it ([`Use`]). From that one list come:
//!
//! ```text
//!   [Use::Uniform(frame), Use::Read(materials), Use::Sampled(position, nearest), Use::Storage(radiance)]
//!      │                       │                      │                               │
//!      ├─ binding kinds ─► UniformBuffer          StorageBuffer   SampledImage          StorageImage   (layout)
//!      ├─ writes ───────► Buffer(frame)           Buffer(materials) Image{position,…}   StorageImage   (descriptor set)
//!      └─ accesses ─────► AnyShaderUniformRead    ComputeStorageRead ComputeSampledRead ComputeStorageWrite
//!                                                  └──────── one batched barrier before the pass (Cmd::uses)
//! ```
//!
//! and the image usage of each image ([`Use::usage`]): declared to a planned image when the
//! set is written, so that it is made with the union of its passes' uses (`image.rs`). The stage half of each access is the pass's: compute or graphics
//! ([`Shaders`]).

use super::access::Access;
use super::cmd::{Attachment, Cmd, Resource};
use super::image::Image;
use super::pipeline::{BindingKind, Write};
use super::resources::{Buffer, Sampler};
use ash::vk;

/// Where a pass's shaders run: the stage half of the accesses it declares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shaders {
    Compute,
    /// Vertex and fragment shaders (buffers read by both; images sampled by fragments).
    Graphics,
}

/// One binding of a pass: a resource and how the pass's shaders use it.
#[derive(Clone, Copy)]
pub enum Use<'a> {
    /// A uniform buffer of per-frame constants: [`Cmd::update_buffer`] leaves it readable by
    /// every shader, so it needs no barrier of its own.
    Uniform(&'a Buffer),
    /// A storage buffer the shaders only read.
    Read(&'a Buffer),
    /// A storage buffer the shaders write (and may read).
    Write(&'a Buffer),
    /// A storage buffer bound but not read by this dispatch, so it needs no barrier (the
    /// tiled gather's first dispatch clears its targets from a photon buffer without photons,
    /// which may belong to another queue).
    Bound(&'a Buffer),
    /// An image sampled (or fetched) through `sampler`.
    Sampled(&'a Image, &'a Sampler),
    /// A storage image written (and maybe read).
    Storage(&'a Image),
    /// A storage image only read.
    StorageRead(&'a Image),
}

impl<'a> Use<'a> {
    /// The descriptor type of its binding.
    pub fn kind(&self) -> BindingKind {
        match self {
            Use::Uniform(_) => BindingKind::UniformBuffer,
            Use::Read(_) | Use::Write(_) | Use::Bound(_) => BindingKind::StorageBuffer,
            Use::Sampled(..) => BindingKind::SampledImage,
            Use::Storage(_) | Use::StorageRead(_) => BindingKind::StorageImage,
        }
    }

    /// What its binding is written with.
    pub fn write(&self) -> Write<'a> {
        match *self {
            Use::Uniform(b) | Use::Read(b) | Use::Write(b) | Use::Bound(b) => Write::Buffer(b),
            Use::Sampled(image, sampler) => Write::Image { image, sampler },
            Use::Storage(image) | Use::StorageRead(image) => Write::StorageImage(image),
        }
    }

    /// The access a pass with `shaders` makes of the resource, for its barrier (none for a
    /// uniform buffer or a [`Use::Bound`] one).
    pub fn access(&self, shaders: Shaders) -> Option<(Resource<'a>, Access)> {
        let compute = shaders == Shaders::Compute;
        let pick = |c, g| if compute { c } else { g };
        Some(match *self {
            Use::Uniform(_) | Use::Bound(_) => return None,
            Use::Read(b) => (
                Resource::Buffer(b),
                pick(Access::ComputeStorageRead, Access::GraphicsStorageRead),
            ),
            Use::Write(b) => {
                debug_assert!(compute, "{}: graphics passes write attachments", b.name);
                (Resource::Buffer(b), Access::ComputeStorageWrite)
            }
            Use::Sampled(image, _) => (
                Resource::Image(image),
                pick(Access::ComputeSampledRead, Access::FragmentSampledRead),
            ),
            Use::Storage(image) => {
                debug_assert!(compute, "{}: graphics passes write attachments", image.name);
                (Resource::Image(image), Access::ComputeStorageWrite)
            }
            Use::StorageRead(image) => {
                debug_assert!(compute, "{}: storage images are compute's", image.name);
                (Resource::Image(image), Access::ComputeStorageRead)
            }
        })
    }

    /// The image usage this use needs (none for buffers): added to a planned image, checked
    /// against a made one ([`writes`]).
    pub fn usage(&self) -> vk::ImageUsageFlags {
        match self {
            Use::Sampled(..) => vk::ImageUsageFlags::SAMPLED,
            Use::Storage(_) | Use::StorageRead(_) => vk::ImageUsageFlags::STORAGE,
            _ => vk::ImageUsageFlags::empty(),
        }
    }
}

/// The binding kinds of `uses`, bindings 0, 1, 2… in order.
pub fn kinds(uses: &[Use]) -> Vec<BindingKind> {
    uses.iter().map(Use::kind).collect()
}

/// The descriptor writes of `uses`, bindings 0, 1, 2… in order; each image's use is declared
/// to it ([`Image::require`]): added to the usage of an image still planned, checked against
/// one made.
///
/// # Panics
/// When a made image lacks the usage its binding needs (its use was declared after
/// [`crate::gpu::Gpu::make_planned`] made it).
pub fn writes<'a>(uses: &[Use<'a>]) -> Vec<Write<'a>> {
    for u in uses {
        if let Use::Sampled(image, _) | Use::Storage(image) | Use::StorageRead(image) = u {
            image.require(u.usage(), format_args!("{:?}", u.kind()));
        }
    }
    uses.iter().map(Use::write).collect()
}

impl Cmd<'_> {
    /// The barriers before a pass with `shaders` that uses `uses`: one batch.
    pub fn uses(&self, shaders: Shaders, uses: &[Use]) {
        let accesses: Vec<_> = uses.iter().filter_map(|u| u.access(shaders)).collect();
        self.barriers(&accesses);
    }

    /// Begins a raster pass that uses `uses` and draws into `colors` (+ `depth`): the barriers
    /// for both in one batch, then dynamic rendering ([`Cmd::begin_rendering`]).
    pub fn begin_pass(&self, uses: &[Use], colors: &[Attachment], depth: Option<&Attachment>) {
        let accesses: Vec<_> = (uses.iter())
            .filter_map(|u| u.access(Shaders::Graphics))
            .collect();
        self.begin_rendering_after(&accesses, colors, depth);
    }
}
