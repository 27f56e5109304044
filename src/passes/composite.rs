//! Composite (compute): radiance += indirect, so the tonemapper and the EXR see direct plus
//! photon-mapped indirect light.

use super::ComputeKernel;
use crate::gpu::{Cmd, Filter, Gpu, Image, Sampler, Shaders, Use};
use crate::timing::pass_id::PassId;
use std::sync::Arc;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    width: u32,
    height: u32,
}

pub struct CompositePass {
    kernel: ComputeKernel,
    sampler: Sampler,
}

impl CompositePass {
    pub fn new(gpu: &Arc<Gpu>, indirect: &Image, radiance: &Image) -> anyhow::Result<Self> {
        let sampler = Sampler::new(gpu, "composite.nearest", Filter::Nearest, false)?;
        let kernel = ComputeKernel::new(
            gpu,
            PassId::Composite.name(),
            &crate::gpu::shader_table::COMPOSITE_COMP,
            &Self::uses(indirect, radiance, &sampler),
            size_of::<Push>() as u32,
            &[],
        )?;
        Ok(Self { kernel, sampler })
    }

    /// What the pass uses, in the shader's binding order.
    fn uses<'a>(indirect: &'a Image, radiance: &'a Image, sampler: &'a Sampler) -> [Use<'a>; 2] {
        [Use::Sampled(indirect, sampler), Use::Storage(radiance)]
    }

    pub fn record(&self, cmd: &Cmd, indirect: &Image, radiance: &mut Image) {
        let _scope = cmd.scope(PassId::Composite.name());
        cmd.uses(
            Shaders::Compute,
            &Self::uses(indirect, radiance, &self.sampler),
        );
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
