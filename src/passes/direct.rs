//! Deferred direct illumination (compute): per eye G-buffer pixel, the sum over lights of
//! BSDF × irradiance × cosine × shadow visibility (3×3 bilinear PCF in the shadow atlas),
//! plus emission, into the HDR radiance image.
//!
//! At `--subsample N > 1` it also writes `lambert`, the pixel's Lambertian lobe's BRDF `c_L/π`
//! (albedo and Fresnel factor at its own view direction; a = 1 where the BSDF faces the eye),
//! which the upsample multiplies the interpolated irradiance by (`passes/upsample.rs`): the
//! material and albedo are read and the BSDF made here anyway, and doing it again in the
//! upsample was 40 % of that pass on lavapipe (docs/performance.md, "The upsample's cost").

use super::eye_gbuffer::GBuffer;
use super::ComputeKernel;
use crate::gpu::{vk, Buffer, Cmd, Filter, Gpu, Image, Sampler, Shaders, SpecConstant, Use};
use crate::layout::shared_constants::SPEC_ID_WRITE_LAMBERT;
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

/// The image of the Lambertian lobe's BRDF the pass writes at `--subsample N > 1` (RGBA32F:
/// `c_L/π`, a = 1 where the BSDF faces the eye, 0 on the background and at grazing views).
/// Planned: the passes that bind it add their uses. Its own: the upsample's read, which may be
/// made after the image (the photon part of the frame, made when the camera moves), and the
/// copy out of it (read back by the tests).
pub fn lambert_output(gpu: &Arc<Gpu>, width: u32, height: u32) -> Image {
    let usage = vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_SRC;
    super::planned_rgba32f(gpu, "lambert", (width, height), usage)
}

/// What the direct pass writes: the radiance, and `c_L/π` where an upsample reads it.
pub struct DirectOutputs<'a> {
    pub radiance: &'a Image,
    pub lambert: Option<&'a Image>,
}

pub struct DirectPass {
    kernel: ComputeKernel,
    nearest: Sampler,
    shadow: Sampler,
    /// Made with a `lambert` output (the shader writes it).
    writes_lambert: bool,
}

impl DirectPass {
    /// The pass with the über-BSDF lobes of `variant` compiled in, writing `outputs.lambert`
    /// where there is one (and only then: the record must be given the same outputs).
    pub fn new(
        gpu: &Arc<Gpu>,
        inputs: &DirectInputs,
        outputs: &DirectOutputs,
        variant: BsdfVariant,
    ) -> anyhow::Result<Self> {
        let nearest = Sampler::new(gpu, "direct.nearest", Filter::Nearest, false)?;
        let shadow = Sampler::new(gpu, "direct.shadow_compare", Filter::LinearCompare, false)?;
        let [glossy, delta] = super::bsdf_constants(variant);
        let kernel = ComputeKernel::new(
            gpu,
            PassId::Direct.name(),
            &crate::gpu::shader_table::DIRECT_COMP,
            &Self::uses(inputs, outputs, (&nearest, &shadow)),
            0,
            &[
                glossy,
                delta,
                SpecConstant::bool(SPEC_ID_WRITE_LAMBERT, outputs.lambert.is_some()),
            ],
        )?;
        Ok(Self {
            kernel,
            nearest,
            shadow,
            writes_lambert: outputs.lambert.is_some(),
        })
    }

    /// What the pass uses, in the shader's binding order.
    fn uses<'a>(
        inputs: &DirectInputs<'a>,
        outputs: &DirectOutputs<'a>,
        (nearest, shadow): (&'a Sampler, &'a Sampler),
    ) -> [Use<'a>; 11] {
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
            Use::Storage(outputs.radiance),
            // Without a reflectance image the shader never writes this binding.
            Use::Storage(outputs.lambert.unwrap_or(outputs.radiance)),
        ]
    }

    /// Records the pass into `radiance` (and `lambert`: the image the pass was made with, if
    /// any).
    pub fn record(
        &self,
        cmd: &Cmd,
        inputs: &DirectInputs,
        (radiance, lambert): (&mut Image, Option<&mut Image>),
    ) {
        // The shader writes `lambert` as it was made to: an image it was not given would be
        // written with no barrier.
        assert_eq!(
            lambert.is_some(),
            self.writes_lambert,
            "the direct pass records with the outputs it was made with"
        );
        let _scope = cmd.scope(PassId::Direct.name());
        let outputs = DirectOutputs {
            radiance,
            lambert: lambert.map(|l| &*l),
        };
        let uses = Self::uses(inputs, &outputs, (&self.nearest, &self.shadow));
        cmd.uses(Shaders::Compute, &uses);
        self.kernel
            .dispatch(cmd, super::image_groups(radiance.width, radiance.height));
    }
}
