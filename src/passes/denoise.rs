//! Denoise (compute, graphics queue): an edge-avoiding à-trous wavelet filter (Dammertz,
//! Sewtz, Hanika & Lensch, HPG 2010) over the global photons' share of the density estimate,
//! right after the support normalisation (`support.rs`) and before the upsample (at
//! `--subsample N > 1` it filters the low-resolution irradiance, each pixel standing for the
//! G-buffer pixel at the centre of its N×N block) and the composite. Caustic photons are never
//! filtered: the pass takes the support pass's normalised global share G/f out of the
//! estimate (split), filters it level by level (ping-pong between the share image and a
//! scratch image, so the share image is overwritten), and adds the result back (merge).
//!
//! ```text
//!   level 0   taps 1 px apart     ·····        5×5 B3-spline taps, each weighted by how alike
//!   level 1   taps 2 px apart    · · · · ·     its surface is to the centre's: normal, distance
//!   level 2   taps 4 px apart   ·   ·   ·      from the centre's tangent plane, albedo
//!   …         (2^k)                            (`glsl/denoise.comp`)
//! ```
//!
//! Why: a photon-map estimate's noise is not per pixel but per kernel, blotches as wide as the
//! kernels, which a per-pixel filter cannot see and many frames are needed to average away
//! (docs/accuracy.md, "The denoiser"). L levels reach ±2·(2^L − 1) pixels at the cost of L
//! passes of 25 taps, and the geometric weights keep the filter on one surface: walls, corners
//! and silhouettes stay sharp. A level filters a pixel only while its step is at most `reach`
//! × the pixel's mean global kernel radius on screen (the support pass writes that radius
//! beside G/f): the blotches' scale, no wider. There is no colour stop, so it also blurs real detail
//! of the indirect light smaller than its reach within a surface: bias.
//!
//! **It vanishes as frames accumulate.** Frame i of a progressive accumulation (i = 0, 1, …)
//! is filtered with `levels(L, i) = L − ⌊log₂(i + 1)⌋` levels (none from frame i = 2^L − 1,
//! the 2^L-th, on) at `reach = 1/√(i + 1)` ([`reach_for`]),
//! so the accumulated mean, whose kernels shrink to converge, converges to the same limit: the
//! filtered frames are a fixed number, their share of the mean falls as 1/N. A frame that is
//! not accumulated (a moving camera, `bench`) gets all L levels.
//!
//! Reads: the eye G-buffer (`ComputeSampledRead`). Reads and writes: the estimate (`indirect`,
//! or the low-resolution irradiance), the support pass's global-share image and a scratch
//! image of its size (`ComputeStorageRead` / `ComputeStorageWrite`).

use super::eye_gbuffer::GBuffer;
use super::ComputeKernel;
use crate::gpu::{vk, Cmd, Filter, Gpu, Image, ImageDesc, Sampler, Shaders, Use, ViewKind};
use crate::timing::pass_id::PassId;
use std::sync::Arc;

/// Exponent of the normal-similarity weight: 2^`DENOISE_NORMAL_POWER_LOG2`
/// (`layout::shared_constants`), which the shader raises by squaring.
pub const NORMAL_POWER: f32 =
    (1u32 << crate::layout::shared_constants::DENOISE_NORMAL_POWER_LOG2) as f32;
/// Tangent-plane distance, relative to the distance from the camera, at which the plane weight
/// falls to 1/e.
pub const PLANE_SIGMA: f32 = 0.01;
/// Albedo difference (RGB distance) at which the albedo weight falls to 1/e.
pub const ALBEDO_SIGMA: f32 = 0.1;
/// Levels of a frame that starts an accumulation, or is not accumulated (`--denoise`'s
/// default): taps up to ±62 pixels apart.
pub const DEFAULT_LEVELS: u32 = 5;
/// The most levels `--denoise` accepts (taps ±2·(2^8 − 1) = ±510 pixels).
pub const MAX_LEVELS: u32 = 8;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    size: [u32; 2],
    g_size: [u32; 2],
    /// [`Mode::Filter`]: pixels between taps, 2^level.
    step: i32,
    subsample: u32,
    mode: u32,
    plane_sigma: f32,
    albedo_sigma: f32,
    /// One image pixel's size per metre of distance at the image's centre, `2·tan(fov/2)/height`
    /// (the low-resolution pixels at `--subsample N > 1`).
    pixel_angle: f32,
    /// A level filters a pixel while its step is at most `reach` × its kernel radius on screen.
    reach: f32,
}

/// What a dispatch does (`glsl/denoise.comp`).
#[derive(Clone, Copy)]
enum Mode {
    /// `total −= src`: the estimate keeps its caustic photons' share.
    Split = 0,
    /// `dst` = one level of the filter over `src`.
    Filter = 1,
    /// `total += src`: the filtered global share back.
    Merge = 2,
}

/// The levels frame `accumulated` (frames already in the mean: 0 for the first, or for a
/// frame that is not accumulated) gets of `levels` (module docs).
pub fn levels_for(levels: u32, accumulated: u32) -> u32 {
    levels.saturating_sub((accumulated.saturating_add(1)).ilog2())
}

/// How far, in kernel radii on screen, frame `accumulated` filters (module docs):
/// `1/√(accumulated + 1)`, so the filtered frames' bias shrinks as the mean's noise does.
pub fn reach_for(accumulated: u32) -> f32 {
    (f64::from(accumulated) + 1.0).sqrt().recip() as f32
}

pub struct DenoisePass {
    kernel: ComputeKernel,
    sampler: Sampler,
    /// The other half of the ping-pong, the size of the global share.
    scratch: Image,
    subsample: u32,
}

/// Descriptor set reading the global share and writing the scratch image.
const FROM_GLOBAL: usize = 0;
/// Descriptor set reading the scratch image and writing the global share.
const FROM_SCRATCH: usize = 1;

impl DenoisePass {
    /// The filter of `global` (the support pass's normalised global share, `passes/support.rs`)
    /// within `total` (the estimate it is part of, the same size: full resolution, or the
    /// low-resolution irradiance at `--subsample N > 1`, shading the G-buffer pixel at the
    /// centre of each N×N block).
    pub fn new(
        gpu: &Arc<Gpu>,
        gbuffer: &GBuffer,
        (total, global): (&Image, &Image),
        subsample: u32,
    ) -> anyhow::Result<Self> {
        let scratch = Image::planned(
            gpu,
            &ImageDesc {
                name: "indirect.denoise_scratch",
                format: vk::Format::R32G32B32A32_SFLOAT,
                width: global.width,
                height: global.height,
                layers: 1,
                usage: vk::ImageUsageFlags::empty(),
                view: ViewKind::D2,
            },
        );
        let sampler = Sampler::new(gpu, "denoise.nearest", Filter::Nearest, false)?;
        let from_global = Self::uses(gbuffer, total, (global, &scratch), &sampler);
        let from_scratch = Self::uses(gbuffer, total, (&scratch, global), &sampler);
        let kernel = ComputeKernel::with_sets(
            gpu,
            PassId::Denoise.name(),
            &crate::gpu::shader_table::DENOISE_COMP,
            size_of::<Push>() as u32,
            &[&from_global, &from_scratch],
            &[],
        )?;
        Ok(Self {
            kernel,
            sampler,
            scratch,
            subsample: subsample.max(1),
        })
    }

    /// What one dispatch uses, in the shader's binding order: every dispatch binds all three
    /// storage images (the shader declares `src` read, `dst` written, `total` read and
    /// written), whichever the mode uses.
    fn uses<'a>(
        g: &'a GBuffer,
        total: &'a Image,
        (src, dst): (&'a Image, &'a Image),
        sampler: &'a Sampler,
    ) -> [Use<'a>; 6] {
        [
            Use::Sampled(&g.position, sampler),
            Use::Sampled(&g.normal, sampler),
            Use::Sampled(&g.albedo, sampler),
            Use::StorageRead(src),
            Use::Storage(dst),
            Use::Storage(total),
        ]
    }

    /// Filters the global share of `total` with `levels` levels (nothing at 0): takes it out,
    /// filters it, adds it back. `pixel_angle`: a pixel of `total`'s size per metre of
    /// distance (what turns a kernel radius into pixels).
    pub fn record(
        &self,
        cmd: &Cmd,
        gbuffer: &GBuffer,
        (total, global): (&Image, &Image),
        (levels, pixel_angle, reach): (u32, f32, f32),
    ) {
        if levels == 0 {
            return;
        }
        let _scope = cmd.scope(PassId::Denoise.name());
        let push = |mode: Mode, step: i32| Push {
            size: [global.width, global.height],
            g_size: [gbuffer.position.width, gbuffer.position.height],
            step,
            subsample: self.subsample,
            mode: mode as u32,
            plane_sigma: PLANE_SIGMA,
            albedo_sigma: ALBEDO_SIGMA,
            pixel_angle,
            reach,
        };
        let groups = super::image_groups(global.width, global.height);
        let (global, scratch) = (global, &self.scratch);
        let dispatch = |set: usize, mode: Mode, step: i32| {
            let (src, dst) = if set == FROM_GLOBAL {
                (global, scratch)
            } else {
                (scratch, global)
            };
            let uses = Self::uses(gbuffer, total, (src, dst), &self.sampler);
            cmd.uses(Shaders::Compute, &uses);
            self.kernel
                .dispatch_set_with(cmd, set, &push(mode, step), groups);
        };
        // Split: total −= global.
        dispatch(FROM_GLOBAL, Mode::Split, 0);
        // Level k reads one image and writes the other.
        for k in 0..levels {
            let set = if k % 2 == 0 {
                FROM_GLOBAL
            } else {
                FROM_SCRATCH
            };
            dispatch(set, Mode::Filter, 1 << k);
        }
        // Merge: total += the last level's output (in the scratch image after an odd count).
        let set = if levels % 2 == 1 {
            FROM_SCRATCH
        } else {
            FROM_GLOBAL
        };
        dispatch(set, Mode::Merge, 0);
    }
}

#[cfg(test)]
mod tests {
    use super::{levels_for, reach_for};

    #[test]
    fn the_reach_falls_as_the_square_root_of_the_frames() {
        assert_eq!(reach_for(0), 1.0);
        assert!((reach_for(3) - 0.5).abs() < 1e-7);
        assert!((reach_for(15) - 0.25).abs() < 1e-7);
        assert!(reach_for(u32::MAX) > 0.0);
    }

    #[test]
    fn the_filter_halves_its_levels_reach_as_frames_double_and_then_stops() {
        let got: Vec<u32> = (0..34).map(|i| levels_for(5, i)).collect();
        let mut want = vec![5, 4, 4, 3, 3, 3, 3];
        want.extend([2; 8]);
        want.extend([1; 16]);
        want.extend([0; 3]);
        assert_eq!(got, want);
        assert_eq!(levels_for(0, 0), 0);
        assert_eq!(levels_for(3, u32::MAX), 0);
    }
}
