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
    pad: [u32; 3],
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

    /// Runs the first bounce over `views` views of up to `extent` = (width, height) texels.
    pub fn record(&self, cmd: &Cmd, io: &BounceMapIo, extent: (u32, u32), views: u32, seed: u32) {
        let _scope = cmd.scope("bounce_map");
        let g = io.light_gbuffer;
        for image in [&g.position, &g.normal, &g.albedo, &g.material] {
            cmd.transition(image, Access::ComputeSampledRead);
        }
        cmd.transition_buffer(io.bounce_map, Access::ComputeStorageWrite);
        let groups = [super::groups(extent.0), super::groups(extent.1), views];
        self.kernel
            .dispatch_with(cmd, &Push { seed, pad: [0; 3] }, groups);
    }
}
