//! Composite (compute): radiance += indirect, so the tonemapper and the EXR see direct plus
//! photon-mapped indirect light.

use super::ComputeKernel;
use crate::gpu::{Access, BindingKind, Cmd, Filter, Gpu, Image, Sampler, Write};
use crate::pass_id::PassId;
use std::sync::Arc;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    width: u32,
    height: u32,
}

pub struct CompositePass {
    kernel: ComputeKernel,
    _sampler: Sampler,
}

impl CompositePass {
    pub fn new(gpu: &Arc<Gpu>, indirect: &Image, radiance: &Image) -> anyhow::Result<Self> {
        let sampler = Sampler::new(gpu, "composite.nearest", Filter::Nearest, false)?;
        let kernel = ComputeKernel::new(
            gpu,
            PassId::Composite.name(),
            &crate::gpu::shader_table::COMPOSITE_COMP,
            &[BindingKind::SampledImage, BindingKind::StorageImage],
            size_of::<Push>() as u32,
            &[
                Write::Image {
                    image: indirect,
                    sampler: &sampler,
                },
                Write::StorageImage(radiance),
            ],
            &[],
        )?;
        Ok(Self {
            kernel,
            _sampler: sampler,
        })
    }

    pub fn record(&self, cmd: &Cmd, indirect: &Image, radiance: &mut Image) {
        let _scope = cmd.scope(PassId::Composite.name());
        cmd.transition(indirect, Access::ComputeSampledRead);
        cmd.transition(radiance, Access::ComputeStorageWrite);
        let push = Push {
            width: radiance.width,
            height: radiance.height,
        };
        self.kernel.dispatch_with(
            cmd,
            &push,
            super::image_groups(radiance.width, radiance.height),
        );
    }
}
