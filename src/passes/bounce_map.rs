//! Bounce map (compute): the first bounce of every photon, one per light G-buffer texel, in
//! the record layout of DESIGN.md §2.1 (`photon::types::BounceMapPhoton`, 32 bytes). The map
//! is then copied to a host-visible buffer for the CPU trace.

use super::eye_gbuffer::GBuffer;
use super::ComputeKernel;
use crate::gpu::{Access, BindingKind, Buffer, Cmd, Filter, Gpu, Sampler, Write};
use crate::photon::bsdf::BsdfVariant;
use std::sync::Arc;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    seed: u32,
    /// The first view of the dispatch (`gl_GlobalInvocationID.z` counts from it).
    first_view: u32,
    pad: [u32; 2],
}

/// Consecutive views the bounce map is made for in one dispatch: views
/// `first..first + count`, of up to `extent` = (width, height) texels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ViewBatch {
    pub first: u32,
    pub count: u32,
    pub extent: (u32, u32),
}

pub struct BounceMapPass {
    kernel: ComputeKernel,
    _sampler: Sampler,
}

/// What the bounce map reads and writes.
pub struct BounceMapIo<'a> {
    pub materials: &'a Buffer,
    pub views: &'a Buffer,
    pub light_gbuffer: &'a GBuffer,
    /// `BounceMapPhoton[texels]`, device-local.
    pub bounce_map: &'a Buffer,
}

impl BounceMapPass {
    /// The pass with the über-BSDF lobes of `variant` compiled in.
    pub fn new(gpu: &Arc<Gpu>, io: &BounceMapIo, variant: BsdfVariant) -> anyhow::Result<Self> {
        let kinds = [
            BindingKind::StorageBuffer,
            BindingKind::StorageBuffer,
            BindingKind::SampledImage,
            BindingKind::SampledImage,
            BindingKind::SampledImage,
            BindingKind::SampledImage,
            BindingKind::StorageBuffer,
        ];
        let sampler = Sampler::new(gpu, "bounce_map.nearest", Filter::Nearest, false)?;
        let g = io.light_gbuffer;
        let image = |image| Write::Image {
            image,
            sampler: &sampler,
        };
        let kernel = ComputeKernel::new(
            gpu,
            "bounce_map",
            &crate::gpu::shader_table::BOUNCE_MAP_COMP,
            &kinds,
            size_of::<Push>() as u32,
            &[
                Write::Buffer(io.materials),
                Write::Buffer(io.views),
                image(&g.position),
                image(&g.normal),
                image(&g.albedo),
                image(&g.material),
                Write::Buffer(io.bounce_map),
            ],
            &super::bsdf_constants(variant),
        )?;
        Ok(Self {
            kernel,
            _sampler: sampler,
        })
    }

    /// Runs the first bounce over the views of `batches` (the others' records are left as
    /// they are: a frame that re-traces some lights only writes theirs).
    pub fn record(&self, cmd: &Cmd, io: &BounceMapIo, batches: &[ViewBatch], seed: u32) {
        let _scope = cmd.scope("bounce_map");
        let g = io.light_gbuffer;
        for image in [&g.position, &g.normal, &g.albedo, &g.material] {
            cmd.transition(image, Access::ComputeSampledRead);
        }
        for batch in batches.iter().filter(|b| b.count > 0) {
            // Each dispatch writes its own views' records only, but binds the whole map: the
            // barrier orders the writes for synchronization validation.
            cmd.transition_buffer(io.bounce_map, Access::ComputeStorageWrite);
            let (w, h) = batch.extent;
            let push = Push {
                seed,
                first_view: batch.first,
                pad: [0; 2],
            };
            let groups = [super::groups(w), super::groups(h), batch.count];
            self.kernel.dispatch_with(cmd, &push, groups);
        }
    }
}
