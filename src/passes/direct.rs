//! Deferred direct illumination (compute): per eye G-buffer pixel, the sum over lights of
//! BSDF × irradiance × cosine × shadow visibility (3×3 bilinear PCF in the shadow atlas),
//! plus emission, into the HDR radiance image.

use super::eye_gbuffer::GBuffer;
use crate::gpu::{
    vk, Access, Binding, BindingKind, Buffer, Cmd, ComputeDesc, DescriptorLayout, DescriptorSet,
    Filter, Gpu, Image, Pipeline, Sampler, Write,
};
use std::sync::Arc;

/// The buffers the direct pass reads.
pub struct DirectInputs<'a> {
    pub frame: &'a Buffer,
    pub materials: &'a Buffer,
    pub lights: &'a Buffer,
    pub shadow_views: &'a Buffer,
    pub gbuffer: &'a GBuffer,
    pub shadow_atlas: &'a Image,
}

pub struct DirectPass {
    pipeline: Pipeline,
    _layout: DescriptorLayout,
    set: DescriptorSet,
    _nearest: Sampler,
    _shadow: Sampler,
}

impl DirectPass {
    pub fn new(gpu: &Arc<Gpu>, inputs: &DirectInputs, radiance: &Image) -> anyhow::Result<Self> {
        let c = vk::ShaderStageFlags::COMPUTE;
        let kinds = [
            BindingKind::UniformBuffer,
            BindingKind::StorageBuffer,
            BindingKind::StorageBuffer,
            BindingKind::StorageBuffer,
            BindingKind::SampledImage,
            BindingKind::SampledImage,
            BindingKind::SampledImage,
            BindingKind::SampledImage,
            BindingKind::SampledImage,
            BindingKind::StorageImage,
        ];
        let bindings = Binding::sequence(&kinds, c);
        let layout = DescriptorLayout::new(gpu, "direct", &bindings, 1)?;
        let nearest = Sampler::new(gpu, "direct.nearest", Filter::Nearest, false)?;
        let shadow = Sampler::new(gpu, "direct.shadow_compare", Filter::LinearCompare, false)?;
        let g = inputs.gbuffer;
        let set = layout.allocate(&[
            Write::Buffer(inputs.frame),
            Write::Buffer(inputs.materials),
            Write::Buffer(inputs.lights),
            Write::Buffer(inputs.shadow_views),
            Write::Image {
                image: &g.position,
                sampler: &nearest,
            },
            Write::Image {
                image: &g.normal,
                sampler: &nearest,
            },
            Write::Image {
                image: &g.albedo,
                sampler: &nearest,
            },
            Write::Image {
                image: &g.material,
                sampler: &nearest,
            },
            Write::Image {
                image: inputs.shadow_atlas,
                sampler: &shadow,
            },
            Write::StorageImage(radiance),
        ])?;
        let pipeline = Pipeline::compute(
            gpu,
            &ComputeDesc {
                name: "direct",
                shader: &crate::gpu::shader_table::DIRECT_COMP,
                set_layouts: &[&layout],
                push_constant_size: 0,
            },
        )?;
        Ok(Self {
            pipeline,
            _layout: layout,
            set,
            _nearest: nearest,
            _shadow: shadow,
        })
    }

    pub fn record(&self, cmd: &Cmd, inputs: &DirectInputs, radiance: &mut Image) {
        let _scope = cmd.scope("direct");
        let g = inputs.gbuffer;
        for image in [
            &g.position,
            &g.normal,
            &g.albedo,
            &g.material,
            inputs.shadow_atlas,
        ] {
            cmd.transition(image, Access::ComputeSampledRead);
        }
        cmd.transition(radiance, Access::ComputeStorageWrite);
        cmd.bind_pipeline(&self.pipeline);
        cmd.bind_sets(&self.pipeline, 0, &[self.set]);
        cmd.dispatch(
            super::groups(radiance.width),
            super::groups(radiance.height),
            1,
        );
    }
}
