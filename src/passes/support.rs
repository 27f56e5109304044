//! Support normalisation (compute): the boundary correction of the global photons' estimate.
//!
//! A splatted photon spreads its power over its cone kernel (radius r, `photon::kernel`). At a
//! pixel s near a crease (floor beside a wall) or a convex edge, part of the kernel disk around
//! s lies off s's surface, where no photon of that surface can land, so the estimate there is
//! too dark: 0.85 (1 frame) and 0.90 (32 frames) of the path tracer within two pixels of the
//! creases of `cornell(2)` before this pass (`tests/progressive.rs`). This pass measures, per
//! pixel, the share f(s) of the kernel that lies on s's surface, from the eye G-buffer alone:
//!
//! ```text
//!            wall                      M = 4 rings x 4 angles on the tangent disk of radius r̄,
//!             |  x  x                  cone-weighted ((1 − ρ)·ρ per ring); each sample y is
//!       x  x  |x    x   <- absent      projected with view_proj and the G-buffer point p there
//!    x    s   |  x                     decides:
//!       x  x  |x    x                    p on s's plane (|(p − s)·n| < 0.2 r̄, n_p·n > 0.9) : on
//!    floor ---+----------                p nearer than y, y within r̄ of p's plane : off (in the wall)
//!                                        p nearer than y, y far from p's plane   : on (occluded)
//!                                        p farther than y, or background         : off (convex edge)
//!                                        y off screen or behind the eye          : on
//! ```
//!
//! r̄ is the κ-weighted mean kernel radius of the global photons that reached s: the photon
//! volumes write, for global photons only, their contribution G and Σ κ·r beside the estimate
//! and Σ κ into a second target ([`super::photon_volumes::support_targets`]). This pass then
//! rewrites the estimate in place, before the composite:
//!
//! ```text
//!   total ← total − G + G / max(f, SUPPORT_FRACTION_MIN)      (floor ½: a straight convex edge)
//!   share ← (G / max(f, SUPPORT_FRACTION_MIN), r̄)             (for the denoiser, `denoise.rs`)
//! ```
//!
//! (Only pixels with geometry and global photons are rewritten; elsewhere the share keeps
//! (G, Σ κ·r), which is (0, 0) without global photons, and the denoiser leaves such pixels
//! as they are.)
//!
//! Global photons are also kept to their own surface (|n_photon · n_s| ≥ `SUPPORT_NORMAL_COS`,
//! 0.9): a floor photon no longer lights the wall beside it, so f counts exactly the kernels
//! that can reach s. Caustic photons (ρp > `CAUSTIC_PATH_DENSITY`) are neither restricted nor
//! normalised: their density ends where the caustic's light ends, not where geometry does.
//! (An earlier attempt measured the support with the photons' own kNN areas, Σ κ·πr²/k; those
//! areas are themselves truncated at boundaries, and it gave 1.11, or 0.76 with same-surface
//! neighbours.)
//!
//! Measured on `cornell(2)` (`tests/progressive.rs`, ISPM / path tracer, 1 and 32 frames):
//! within two pixels of creases 0.849 / 0.902 before, 0.995 / 1.004 after; elsewhere
//! 0.98 / 0.97 before, 0.993 / 0.967 after. Cost: 33 ms on `cornell-box` at 640×480 on lavapipe
//! with two threads (photon volumes: 1.7 s), stats field `ms.support`. The measured f of the
//! last frame stays in the weight target's G channel (`PhotonFrame::read_support_fraction`,
//! the estimator-equivalence test's CPU gather divides by it).
//!
//! At `--subsample N > 1` the pass runs on the low-resolution targets
//! ([`super::photon_volumes::low_targets`] and the support targets beside them), each pixel
//! standing for the G-buffer pixel at the centre of its N×N block: the irradiance and the glossy
//! estimate are both normalised (the global photons' glossy share rides in the weight target's
//! GBA), before the upsample. Not done: curved surfaces whose curvature over r̄ exceeds the tolerances
//! count as partly off (slightly brightened); f is measured on visible geometry only (a crease
//! hidden from the camera is unknown and counts as surface).

use super::eye_gbuffer::GBuffer;
use super::ComputeKernel;
use crate::gpu::{Buffer, Cmd, Filter, Gpu, Image, Sampler, Shaders, SpecConstant, Use};
use crate::layout::shared_constants::SPEC_ID_SUBSAMPLED;
use crate::timing::pass_id::PassId;
use std::sync::Arc;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    /// The targets' size.
    width: u32,
    height: u32,
    /// The eye G-buffer's.
    g_width: u32,
    g_height: u32,
    subsample: u32,
    pad: [u32; 3],
}

pub struct SupportPass {
    kernel: ComputeKernel,
    sampler: Sampler,
}

impl SupportPass {
    /// The pass over `total` (the full-resolution photon-volume target) and the two
    /// [`super::photon_volumes::support_targets`] beside it, reading the eye G-buffer and the
    /// frame's `view_proj`; at `--subsample N > 1`, `glossy` is the low-resolution glossy target
    /// and `total` the low-resolution irradiance.
    pub fn new(
        gpu: &Arc<Gpu>,
        (frame, gbuffer): (&Buffer, &GBuffer),
        (total, glossy): (&Image, Option<&Image>),
        support: &[Image; 2],
    ) -> anyhow::Result<Self> {
        let sampler = Sampler::new(gpu, "support.nearest", Filter::Nearest, false)?;
        let kernel = ComputeKernel::new(
            gpu,
            PassId::Support.name(),
            &crate::gpu::shader_table::SUPPORT_COMP,
            &Self::uses((frame, gbuffer), (total, glossy), support, &sampler),
            size_of::<Push>() as u32,
            &[SpecConstant::bool(SPEC_ID_SUBSAMPLED, glossy.is_some())],
        )?;
        Ok(Self { kernel, sampler })
    }

    /// What the pass uses, in the shader's binding order (without `glossy`, `total` stands in
    /// for it: the shader then leaves the binding alone).
    fn uses<'a>(
        (frame, gbuffer): (&'a Buffer, &'a GBuffer),
        (total, glossy): (&'a Image, Option<&'a Image>),
        support: &'a [Image; 2],
        sampler: &'a Sampler,
    ) -> [Use<'a>; 7] {
        [
            Use::Uniform(frame),
            Use::Sampled(&gbuffer.position, sampler),
            Use::Sampled(&gbuffer.normal, sampler),
            Use::Storage(total),
            Use::Storage(&support[0]),
            Use::Storage(&support[1]),
            Use::Storage(glossy.unwrap_or(total)),
        ]
    }

    /// Normalises `total` (and at `--subsample N > 1` `glossy`, of the `subsample` the pass was
    /// made for) by the support measured for the global photons of `support`.
    pub fn record(
        &self,
        cmd: &Cmd,
        (frame, gbuffer): (&Buffer, &GBuffer),
        (total, glossy): (&Image, Option<&Image>),
        support: &[Image; 2],
        subsample: u32,
    ) {
        let _scope = cmd.scope(PassId::Support.name());
        let uses = Self::uses((frame, gbuffer), (total, glossy), support, &self.sampler);
        cmd.uses(Shaders::Compute, &uses);
        let (width, height) = (total.width, total.height);
        let push = Push {
            width,
            height,
            g_width: gbuffer.position.width,
            g_height: gbuffer.position.height,
            subsample: subsample.max(1),
            pad: [0; 3],
        };
        self.kernel
            .dispatch_with(cmd, &push, super::image_groups(width, height));
    }
}
