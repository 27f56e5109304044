//! One explicit GPU pass per file. Each pass is a struct with `new` (pipelines and descriptor
//! sets) and `record` (its commands, inside a scope named after the pass, which is both its
//! debug label and its timestamp scope). Inputs are taken by `&`, outputs by `&mut`. Passes
//! whose shaders evaluate the über-BSDF take a [`crate::photon::bsdf::BsdfVariant`] in `new`:
//! the lobes compiled in (specialisation constants, `docs/effects.md`).
//!
//! | pass | queue | reads | writes |
//! |---|---|---|---|
//! | [`shadow_map`] | graphics | scene geometry | shadow atlas (one layer per light view) |
//! | [`light_gbuffer`] | graphics | scene geometry, materials | light G-buffer (a layer per view) |
//! | [`bounce_map`] | graphics (compute) | light G-buffer, materials | bounce map (first bounces) |
//! | [`eye_gbuffer`] | graphics | scene geometry, materials, textures | eye G-buffer |
//! | [`direct`] | graphics (compute) | G-buffer, lights, shadow atlas | HDR radiance (+ `lambert`, c_L/π, at `--subsample N > 1`) |
//! | [`photon_volumes`] | graphics | photon map, eye G-buffer | HDR indirect radiance |
//! | [`upsample`] | graphics (compute) | 1/N indirect, eye G-buffer (position, normal), `lambert` | HDR indirect |
//! | [`composite`] | graphics (compute) | indirect | HDR radiance (+= indirect) |
//! | [`environment`] | graphics | scene geometry (opaque), lights, shadow atlas | environment cube map (cached) |
//! | [`translucent`] | graphics | delta instances, lights, shadow atlas, cube map, eye depth | HDR radiance (over) |
//! | [`tonemap`] | graphics (compute) | HDR radiance | 8-bit display image |
//! | [`value_check`] | graphics (compute) | the HDR images, bounce map and photon map (`--check-values`) | value counters (host-visible) |
//! | [`debug_view`] | graphics (compute) | one intermediate buffer (G-buffers, bounce map, photons, indirect) | 8-bit display image (over) |

pub mod accumulate;
pub mod bounce_map;
pub mod composite;
pub mod debug_view;
pub mod denoise;
pub mod direct;
pub mod environment;
pub mod eye_gbuffer;
pub mod light_gbuffer;
pub mod photon_tiles;
pub mod photon_volumes;
pub mod shadow_map;
pub mod support;
pub mod tonemap;
pub mod translucent;
pub mod upsample;
pub mod value_check;

use crate::gpu::Use;

/// The specialisation constants that select `variant`'s lobes in every shader including
/// `bsdf.glsl`.
pub(crate) fn bsdf_constants(
    variant: crate::photon::bsdf::BsdfVariant,
) -> [crate::gpu::SpecConstant; 2] {
    variant
        .constants()
        .map(|(id, on)| crate::gpu::SpecConstant::bool(id, on))
}

/// A planned full-screen RGBA32F image (`gpu/image.rs`): made by the next
/// [`crate::gpu::Gpu::make_planned`] with `usage` and every use the passes declare before it.
pub(crate) fn planned_rgba32f(
    gpu: &std::sync::Arc<crate::gpu::Gpu>,
    name: &str,
    (width, height): (u32, u32),
    usage: crate::gpu::vk::ImageUsageFlags,
) -> crate::gpu::Image {
    crate::gpu::Image::planned(
        gpu,
        &crate::gpu::ImageDesc {
            name,
            format: crate::gpu::vk::Format::R32G32B32A32_SFLOAT,
            width,
            height,
            layers: 1,
            usage,
            view: crate::gpu::ViewKind::D2,
        },
    )
}

/// The vertex layout every raster pass reads (see [`crate::layout::Vertex`]).
pub(crate) fn vertex_attributes() -> [crate::gpu::VertexAttribute; 3] {
    use crate::gpu::{vk, VertexAttribute};
    [
        VertexAttribute {
            location: 0,
            format: vk::Format::R32G32B32_SFLOAT,
            offset: 0,
        },
        VertexAttribute {
            location: 1,
            format: vk::Format::R32G32B32_SFLOAT,
            offset: 12,
        },
        VertexAttribute {
            location: 2,
            format: vk::Format::R32G32_SFLOAT,
            offset: 24,
        },
    ]
}

/// What every compute pass owns: its pipeline and its descriptor sets (one, or one per buffer
/// of a map split over several: [`ComputeKernel::with_sets`]), made from the pass's declared
/// [`Use`]s (bindings 0, 1, 2… in the order the shader declares them; the same list gives the
/// barriers before each dispatch, [`crate::gpu::Cmd::uses`]), and the pipeline's
/// specialisation constants. The pass keeps its samplers itself, since the uses borrow them.
pub(crate) struct ComputeKernel {
    pipeline: crate::gpu::Pipeline,
    layout: crate::gpu::DescriptorLayout,
    sets: Vec<crate::gpu::DescriptorSet>,
}

impl ComputeKernel {
    pub(crate) fn new(
        gpu: &std::sync::Arc<crate::gpu::Gpu>,
        name: &str,
        shader: &crate::gpu::Shader,
        uses: &[Use],
        push_constant_size: u32,
        specialization: &[crate::gpu::SpecConstant],
    ) -> anyhow::Result<Self> {
        let sets = [uses];
        Self::with_sets(gpu, name, shader, push_constant_size, &sets, specialization)
    }

    /// The kernel with one descriptor set per entry of `sets` (e.g. one per buffer of a bounce
    /// map or photon map split over several), chosen at each dispatch
    /// ([`ComputeKernel::dispatch_set_with`]). Every set declares the same kinds of binding.
    pub(crate) fn with_sets(
        gpu: &std::sync::Arc<crate::gpu::Gpu>,
        name: &str,
        shader: &crate::gpu::Shader,
        push_constant_size: u32,
        sets: &[&[Use]],
        specialization: &[crate::gpu::SpecConstant],
    ) -> anyhow::Result<Self> {
        use crate::gpu::uses;
        let kinds = uses::kinds(sets.first().copied().unwrap_or_default());
        assert!(
            sets.iter().all(|s| uses::kinds(s) == kinds),
            "{name}: every descriptor set declares the same bindings"
        );
        let writes: Vec<_> = sets.iter().map(|s| uses::writes(s)).collect();
        let writes: Vec<_> = writes.iter().map(Vec::as_slice).collect();
        let shape = (&kinds[..], push_constant_size);
        Self::build(gpu, (name, shader), shape, &writes, specialization)
    }

    /// The kernel with `sets` descriptor sets of bindings `kinds`, written only when each is
    /// dispatched ([`ComputeKernel::rewrite`]): for a pass whose inputs change from dispatch
    /// to dispatch (the value check's).
    pub(crate) fn unwritten(
        gpu: &std::sync::Arc<crate::gpu::Gpu>,
        (name, shader): (&str, &crate::gpu::Shader),
        (kinds, push_constant_size): (&[crate::gpu::BindingKind], u32),
        sets: usize,
    ) -> anyhow::Result<Self> {
        let unwritten: Vec<&[crate::gpu::Write]> = vec![&[]; sets];
        let shape = (kinds, push_constant_size);
        Self::build(gpu, (name, shader), shape, &unwritten, &[])
    }

    fn build(
        gpu: &std::sync::Arc<crate::gpu::Gpu>,
        (name, shader): (&str, &crate::gpu::Shader),
        (kinds, push_constant_size): (&[crate::gpu::BindingKind], u32),
        sets: &[&[crate::gpu::Write]],
        specialization: &[crate::gpu::SpecConstant],
    ) -> anyhow::Result<Self> {
        use crate::gpu::{vk, Binding, ComputeDesc, DescriptorLayout, Pipeline};
        let bindings = Binding::sequence(kinds, vk::ShaderStageFlags::COMPUTE);
        let layout = DescriptorLayout::new(gpu, name, &bindings, sets.len().max(1) as u32)?;
        let sets = sets
            .iter()
            .map(|writes| layout.allocate(writes))
            .collect::<Result<Vec<_>, _>>()?;
        let pipeline = Pipeline::compute(
            gpu,
            &ComputeDesc {
                name,
                shader,
                set_layouts: &[&layout],
                push_constant_size,
                specialization,
            },
        )?;
        Ok(Self {
            pipeline,
            layout,
            sets,
        })
    }

    /// Points descriptor set `set` at `uses` (the kinds declared when it was made). No command
    /// buffer that bound the set may be recording or pending.
    pub(crate) fn rewrite(&self, set: usize, uses: &[Use]) {
        self.layout
            .update(self.sets[set], &crate::gpu::uses::writes(uses));
    }

    /// Binds the kernel and dispatches `groups` workgroups.
    pub(crate) fn dispatch(&self, cmd: &crate::gpu::Cmd, groups: [u32; 3]) {
        cmd.bind_pipeline(&self.pipeline);
        cmd.bind_sets(&self.pipeline, 0, &self.sets[..1]);
        cmd.dispatch(groups[0], groups[1], groups[2]);
    }

    /// [`ComputeKernel::dispatch`] with `push` as the push constants.
    pub(crate) fn dispatch_with<T: bytemuck::Pod>(
        &self,
        cmd: &crate::gpu::Cmd,
        push: &T,
        groups: [u32; 3],
    ) {
        self.dispatch_set_with(cmd, 0, push, groups);
    }

    /// [`ComputeKernel::dispatch_with`] with descriptor set `set` of [`ComputeKernel::with_sets`].
    pub(crate) fn dispatch_set_with<T: bytemuck::Pod>(
        &self,
        cmd: &crate::gpu::Cmd,
        set: usize,
        push: &T,
        groups: [u32; 3],
    ) {
        cmd.bind_pipeline(&self.pipeline);
        cmd.bind_sets(&self.pipeline, 0, &self.sets[set..=set]);
        cmd.push_constants(&self.pipeline, push);
        cmd.dispatch(groups[0], groups[1], groups[2]);
    }
}

/// Workgroups covering a `width`×`height` image, one layer.
pub(crate) fn image_groups(width: u32, height: u32) -> [u32; 3] {
    [groups(width), groups(height), 1]
}

/// Workgroup size (x and y) of the per-pixel compute passes; matches `local_size` in GLSL.
pub(crate) const TILE: u32 = 8;

/// Workgroups needed to cover `n` pixels.
pub(crate) fn groups(n: u32) -> u32 {
    n.div_ceil(TILE)
}
