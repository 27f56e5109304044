//! Deferred direct illumination (compute): per eye G-buffer pixel, the sum over lights of
//! BSDF × irradiance × cosine × shadow visibility (3×3 bilinear PCF in the shadow atlas),
//! plus emission, into the HDR radiance image.

use super::eye_gbuffer::GBuffer;
use super::ComputeKernel;
use crate::gpu::{Buffer, Cmd, Filter, Gpu, Image, Sampler, Shaders, Use};
use crate::photon::bsdf::BsdfVariant;
use crate::timing::pass_id::PassId;
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
    nearest: Sampler,
    shadow: Sampler,
}

impl DirectPass {
    /// The pass with the über-BSDF lobes of `variant` compiled in.
    pub fn new(
        gpu: &Arc<Gpu>,
        inputs: &DirectInputs,
        radiance: &Image,
        variant: BsdfVariant,
    ) -> anyhow::Result<Self> {
        let nearest = Sampler::new(gpu, "direct.nearest", Filter::Nearest, false)?;
        let shadow = Sampler::new(gpu, "direct.shadow_compare", Filter::LinearCompare, false)?;
        let kernel = ComputeKernel::new(
            gpu,
            PassId::Direct.name(),
            &crate::gpu::shader_table::DIRECT_COMP,
            &Self::uses(inputs, radiance, (&nearest, &shadow)),
            0,
            &super::bsdf_constants(variant),
        )?;
        Ok(Self {
            kernel,
            nearest,
            shadow,
        })
    }

    /// What the pass uses, in the shader's binding order.
    fn uses<'a>(
        inputs: &DirectInputs<'a>,
        radiance: &'a Image,
        (nearest, shadow): (&'a Sampler, &'a Sampler),
    ) -> [Use<'a>; 10] {
        let g = inputs.gbuffer;
        [
            Use::Uniform(inputs.frame),
            Use::Read(inputs.materials),
            Use::Read(inputs.lights),
            Use::Read(inputs.shadow_views),
            Use::Sampled(&g.position, nearest),
            Use::Sampled(&g.normal, nearest),
            Use::Sampled(&g.albedo, nearest),
            Use::Sampled(&g.material, nearest),
            Use::Sampled(inputs.shadow_atlas, shadow),
            Use::Storage(radiance),
        ]
    }

    pub fn record(&self, cmd: &Cmd, inputs: &DirectInputs, radiance: &mut Image) {
        let _scope = cmd.scope(PassId::Direct.name());
        let uses = Self::uses(inputs, radiance, (&self.nearest, &self.shadow));
        cmd.uses(Shaders::Compute, &uses);
        self.kernel
            .dispatch(cmd, super::image_groups(radiance.width, radiance.height));
    }
}
