//! Composite (compute): radiance += indirect, so the tonemapper and the EXR see direct plus
//! photon-mapped indirect light.

use crate::gpu::{
    vk, Access, Binding, BindingKind, Cmd, ComputeDesc, DescriptorLayout, DescriptorSet, Filter,
    Gpu, Image, Pipeline, Sampler, Write,
};
use std::sync::Arc;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    width: u32,
    height: u32,
}

pub struct CompositePass {
    pipeline: Pipeline,
    _layout: DescriptorLayout,
    set: DescriptorSet,
    _sampler: Sampler,
}

impl CompositePass {
    pub fn new(gpu: &Arc<Gpu>, indirect: &Image, radiance: &Image) -> anyhow::Result<Self> {
        let c = vk::ShaderStageFlags::COMPUTE;
        let layout = DescriptorLayout::new(
            gpu,
            "composite",
            &[
                Binding {
                    binding: 0,
                    kind: BindingKind::SampledImage,
                    stages: c,
                },
                Binding {
                    binding: 1,
                    kind: BindingKind::StorageImage,
                    stages: c,
                },
            ],
            1,
        )?;
        let sampler = Sampler::new(gpu, "composite.nearest", Filter::Nearest, false)?;
        let set = layout.allocate(&[
            Write::Image {
                image: indirect,
                sampler: &sampler,
            },
            Write::StorageImage(radiance),
        ])?;
        let pipeline = Pipeline::compute(
            gpu,
            &ComputeDesc {
                name: "composite",
                shader: &crate::gpu::shader_table::COMPOSITE_COMP,
                set_layouts: &[&layout],
                push_constant_size: size_of::<Push>() as u32,
            },
        )?;
        Ok(Self {
            pipeline,
            _layout: layout,
            set,
            _sampler: sampler,
        })
    }

    pub fn record(&self, cmd: &Cmd, indirect: &Image, radiance: &mut Image) {
        let _scope = cmd.scope("composite");
        cmd.transition(indirect, Access::ComputeSampledRead);
        cmd.transition(radiance, Access::ComputeStorageWrite);
        cmd.bind_pipeline(&self.pipeline);
        cmd.bind_sets(&self.pipeline, 0, &[self.set]);
        cmd.push_constants(
            &self.pipeline,
            &Push {
                width: radiance.width,
                height: radiance.height,
            },
        );
        cmd.dispatch(
            super::groups(radiance.width),
            super::groups(radiance.height),
            1,
        );
    }
}
