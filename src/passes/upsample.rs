//! Upsample (compute, graphics queue): the second half of `--subsample N` (DESIGN.md §2 step 7,
//! paper §5.2). At N > 1 the photon volumes run at ⌈W/N⌉×⌈H/N⌉ and shade, per low-resolution
//! pixel, the surface the full-resolution eye G-buffer holds at the centre of its N×N block
//! (`i·N + N/2`, clamped to the image). They write two low-resolution images:
//!
//! ```text
//!   indirect.low_irradiance  RGBA32F  Σ Φ·κ over front-side photons (a = volumes per pixel)
//!   indirect.low_glossy      RGBA32F  Σ f_glossy·Φ·κ: the non-Lambertian lobes, as radiance
//! ```
//!
//! This pass writes the full-resolution `indirect` that `composite` adds to the radiance: for
//! each pixel, the 2×2 nearest low-resolution samples weighted by
//! `bilinear × max(0, n·n_s)^NORMAL_POWER × exp(−|n·(p_s − p)| / (DEPTH_SIGMA·|p|))`
//! (the depth term is the sample's distance from the pixel's tangent plane, relative to the
//! pixel's distance from the camera, so a plane seen at a grazing angle keeps full weight),
//! normalised; when every weight vanishes the geometrically most similar sample is taken alone.
//! The interpolated irradiance is multiplied by the pixel's own Lambertian BSDF `c_L/π` (its
//! albedo texture and Fresnel factor at full resolution), which the direct pass writes for it
//! (`lambert`, `passes/direct.rs`); the glossy part is interpolated as radiance.
//!
//! What is not consistent (the price of the fill rate): the glossy lobes are evaluated with the
//! low-resolution sample's material, normal and view direction, not the pixel's; the
//! front-side test uses the sample's normal; edges between samples are filtered, so detail
//! smaller than N pixels in the indirect light is lost; and there is no hardware depth test at
//! low resolution (no depth attachment of that size): the kernel test alone culls surfaces
//! outside a volume, which is exact but shades the occluded fragments the depth test would
//! have rejected. At `--subsample 1` none of this runs.
//!
//! [`Upsample::Bilinear`] (`ispm sweep`'s "upsampling off") drops the geometric terms: the
//! weights are bilinear alone (background samples still excluded), so what the joint filter
//! buys at edges and glancing surfaces can be measured against a plain upsample.
//!
//! The fine photons (caustic photons with kernels an N×N block would spread, `photon::kernel::Share`)
//! are not in the low-resolution images when the scene can make any: they are estimated at full
//! resolution and added to `indirect` after this pass (`render/photon_frame/estimate.rs`).
//!
//! Reads: the eye G-buffer's positions and normals, `lambert`, the two low-resolution images
//! (`ComputeSampledRead`).
//! Writes: `indirect` (`ComputeStorageWrite`).

use super::eye_gbuffer::GBuffer;
use super::ComputeKernel;
use crate::config::settings::Upsample;
use crate::gpu::{vk, Cmd, Filter, Gpu, Image, Sampler, Shaders, SpecConstant, Use};
use crate::layout::shared_constants::{SPEC_ID_UPSAMPLE_BLOCK, UPSAMPLE_BLOCK};
use crate::timing::pass_id::PassId;
use std::sync::Arc;

/// Exponent of the normal-similarity weight: 2^`UPSAMPLE_NORMAL_POWER_LOG2`
/// (`layout::shared_constants`), which the shader raises by squaring.
pub const NORMAL_POWER: f32 =
    (1u32 << crate::layout::shared_constants::UPSAMPLE_NORMAL_POWER_LOG2) as f32;
/// Tangent-plane distance, relative to the distance from the camera, at which the depth
/// weight falls to 1/e.
pub const DEPTH_SIGMA: f32 = 0.02;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    size: [u32; 2],
    low_size: [u32; 2],
    subsample: u32,
    depth_sigma: f32,
    /// 1: joint bilateral weights; 0: bilinear only.
    joint: u32,
}

/// The side of the pixel block an invocation shades at subsample `n`: a cell's side `n` split
/// into the fewest blocks of at most `UPSAMPLE_BLOCK`, as even as they go (`n` = 5: 3 + 2, not
/// 4 + 1, so that fewer of the block loop's lanes idle).
fn block(n: u32) -> u32 {
    let n = n.max(1);
    n.div_ceil(n.div_ceil(UPSAMPLE_BLOCK))
}

/// The workgroups covering the image whose `low_size` samples are at subsample `n`, one
/// invocation per block of a cell (upsample.comp): the cells run from −1 (the pixels left of the
/// first sample centre) to the last sample, each ⌈n / block⌉ blocks a side.
fn cell_blocks((low_w, low_h): (u32, u32), n: u32) -> [u32; 3] {
    let k = n.max(1).div_ceil(block(n));
    super::image_groups((low_w + 1) * k, (low_h + 1) * k)
}

/// Low-resolution size of a `width`×`height` image at subsample `n` (at least 1×1).
pub fn low_size(width: u32, height: u32, n: u32) -> (u32, u32) {
    let n = n.max(1);
    (width.div_ceil(n), height.div_ceil(n))
}

/// The full-resolution indirect radiance this pass writes (alpha: volumes per low-res sample).
/// Planned: the passes that bind it add their uses; its own is the copy out of it (read back).
pub fn output(gpu: &Arc<Gpu>, width: u32, height: u32) -> Image {
    let usage = vk::ImageUsageFlags::TRANSFER_SRC;
    super::planned_rgba32f(gpu, "indirect", (width, height), usage)
}

/// What the upsample reads.
pub struct UpsampleInputs<'a> {
    pub gbuffer: &'a GBuffer,
    /// The pixels' `c_L/π` (a = 1 where the BSDF faces the eye), from the direct pass.
    pub lambert: &'a Image,
    /// `[low_irradiance, low_glossy]` from the subsampled photon volumes.
    pub low: &'a [Image; 2],
}

pub struct UpsamplePass {
    kernel: ComputeKernel,
    sampler: Sampler,
    subsample: u32,
    mode: Upsample,
}

impl UpsamplePass {
    pub fn new(
        gpu: &Arc<Gpu>,
        inputs: &UpsampleInputs,
        indirect: &Image,
        subsample: u32,
        mode: Upsample,
    ) -> anyhow::Result<Self> {
        let sampler = Sampler::new(gpu, "upsample.nearest", Filter::Nearest, false)?;
        let kernel = ComputeKernel::new(
            gpu,
            PassId::Upsample.name(),
            &crate::gpu::shader_table::UPSAMPLE_COMP,
            &Self::uses(inputs, indirect, &sampler),
            size_of::<Push>() as u32,
            // upsample.comp's BLOCK.
            &[SpecConstant {
                id: SPEC_ID_UPSAMPLE_BLOCK,
                value: block(subsample),
            }],
        )?;
        Ok(Self {
            kernel,
            sampler,
            subsample,
            mode,
        })
    }

    /// What the pass uses, in the shader's binding order.
    fn uses<'a>(
        inputs: &UpsampleInputs<'a>,
        indirect: &'a Image,
        sampler: &'a Sampler,
    ) -> [Use<'a>; 6] {
        let g = inputs.gbuffer;
        [
            Use::Sampled(&g.position, sampler),
            Use::Sampled(&g.normal, sampler),
            Use::Sampled(inputs.lambert, sampler),
            Use::Sampled(&inputs.low[0], sampler),
            Use::Sampled(&inputs.low[1], sampler),
            Use::Storage(indirect),
        ]
    }

    pub fn record(&self, cmd: &Cmd, inputs: &UpsampleInputs, indirect: &mut Image) {
        let _scope = cmd.scope(PassId::Upsample.name());
        let uses = Self::uses(inputs, indirect, &self.sampler);
        cmd.uses(Shaders::Compute, &uses);
        let low = &inputs.low[0];
        self.kernel.dispatch_with(
            cmd,
            &Push {
                size: [indirect.width, indirect.height],
                low_size: [low.width, low.height],
                subsample: self.subsample,
                depth_sigma: DEPTH_SIGMA,
                joint: u32::from(self.mode == Upsample::Joint),
            },
            cell_blocks((low.width, low.height), self.subsample),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::{block, cell_blocks, low_size};

    /// What upsample.comp does with an invocation id, per axis: the pixels it shades.
    fn pixels(id: u32, n: u32, low: u32, size: u32) -> Vec<u32> {
        let (b, k) = (block(n) as i64, n.div_ceil(block(n)) as i64);
        let (id, n) = (id as i64, n as i64);
        let cell = id / k - 1;
        if cell > low as i64 - 1 {
            return Vec::new();
        }
        let cell_first = cell * n + n / 2;
        let first = cell_first + (id % k) * b;
        let end = (cell_first + n).min(first + b).min(size as i64);
        (first..end).filter(|&p| p >= 0).map(|p| p as u32).collect()
    }

    /// Every pixel is shaded once, by the cell of the samples it lies between (the pixels left
    /// of the first sample's centre by cell −1), for block sizes that split a cell unevenly
    /// and factors up to the image's size.
    #[test]
    fn the_upsample_dispatch_shades_every_pixel_once_from_its_own_cell() {
        for size in [1u32, 2, 7, 47, 61, 64] {
            for n in 2..=size.max(2) + 3 {
                let (low, _) = low_size(size, 1, n);
                let invocations = cell_blocks((low, 1), n)[0] * super::super::TILE;
                let mut count = vec![0u32; size as usize];
                for id in 0..invocations {
                    for p in pixels(id, n, low, size) {
                        count[p as usize] += 1;
                        let cell = (id / n.div_ceil(block(n))) as i64 - 1;
                        let expected = (p as i64 - (n / 2) as i64).div_euclid(n as i64);
                        assert_eq!(cell, expected, "size {size}, n {n}, pixel {p}");
                    }
                }
                assert!(
                    count.iter().all(|&c| c == 1),
                    "size {size}, n {n}: {count:?}"
                );
            }
        }
        assert_eq!(
            (block(4), block(5), block(6), block(7), block(9)),
            (4, 3, 3, 4, 3)
        );
    }

    #[test]
    fn low_size_covers_the_image_and_is_never_empty() {
        assert_eq!(low_size(128, 128, 1), (128, 128));
        assert_eq!(low_size(128, 96, 4), (32, 24));
        assert_eq!(low_size(130, 97, 4), (33, 25));
        assert_eq!(low_size(64, 64, 64), (1, 1));
        assert_eq!(low_size(64, 48, 64), (1, 1));
    }
}
