//! Deferred direct illumination (compute): per eye G-buffer pixel, the sum over lights of
//! BSDF × irradiance × cosine × shadow visibility (3×3 bilinear PCF in the shadow atlas),
//! plus emission, into the HDR radiance image.

use super::eye_gbuffer::GBuffer;
use super::ComputeKernel;
use crate::gpu::{Access, BindingKind, Buffer, Cmd, Filter, Gpu, Image, Sampler, Write};
use crate::pass_id::PassId;
use crate::photon::bsdf::BsdfVariant;
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
    kernel: ComputeKernel,
    _nearest: Sampler,
    _shadow: Sampler,
}

impl DirectPass {
    /// The pass with the über-BSDF lobes of `variant` compiled in.
    pub fn new(
        gpu: &Arc<Gpu>,
        inputs: &DirectInputs,
        radiance: &Image,
        variant: BsdfVariant,
    ) -> anyhow::Result<Self> {
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
        let nearest = Sampler::new(gpu, "direct.nearest", Filter::Nearest, false)?;
        let shadow = Sampler::new(gpu, "direct.shadow_compare", Filter::LinearCompare, false)?;
        let g = inputs.gbuffer;
        let writes = [
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
        ];
        let kernel = ComputeKernel::new(
            gpu,
            PassId::Direct.name(),
            &crate::gpu::shader_table::DIRECT_COMP,
            &kinds,
            0,
            &writes,
            &super::bsdf_constants(variant),
        )?;
        Ok(Self {
            kernel,
            _nearest: nearest,
            _shadow: shadow,
        })
    }

    pub fn record(&self, cmd: &Cmd, inputs: &DirectInputs, radiance: &mut Image) {
        let _scope = cmd.scope(PassId::Direct.name());
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
        self.kernel
            .dispatch(cmd, super::image_groups(radiance.width, radiance.height));
    }
}
