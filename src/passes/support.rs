//! Support normalisation (compute): the boundary correction of the global photons' estimate.
//!
//! A splatted photon spreads its power over its kernel disk; near the edge of a surface part of
//! the disk lies off it, and near a corner part lies inside the other wall, so the estimate at
//! pixels near edges and corners is too dark (13–14 % within two pixels of the creases of a
//! closed room, `tests/progressive.rs`, before this pass). The fix is the kernel's support on
//! the surface, measured by the photons themselves. Each global photon stands for the surface
//! area `a = π r² / k` around it (`r` its k-nearest-neighbour radius, `photon::density`: its k
//! neighbours cover `π r²`), so at a pixel `s`
//!
//! ```text
//!   W(s) = Σᵢ κᵢ(s)·aᵢ  ≈  ∫ κ(s, y) dA(y) over the surfaces photons land on
//!          1 inside a surface, ½ at a straight convex edge, between at corners
//!   L(s) = Σ caustic fᵢ Φᵢ κᵢ  +  (Σ global fᵢ Φᵢ κᵢ) / max(W, SUPPORT_WEIGHT_MIN)
//! ```
//!
//! — Shepard's normalisation of a kernel estimate, with the photon density as the sampling
//! density. The photon volumes write the global photons' sum `G` and `W` beside the full
//! estimate (`glsl/photon_volumes*.frag`, [`super::photon_volumes::global_targets`]); this pass
//! replaces `G` by `G / max(W, SUPPORT_WEIGHT_MIN)` in place, before the composite (or, at
//! `--subsample N`, in both low-resolution targets before the upsample). Caustic photons are
//! not normalised: their density ends where the caustic ends, which is light, not geometry,
//! and normalising would smear the caustic's edge outwards. The floor (¼, a convex corner)
//! keeps a pixel with one stray photon from being multiplied up. The ratio is consistent: as
//! kernels shrink (progressive accumulation) `W` → 1 away from the boundary, and the boundary
//! band shrinks with them.

use super::ComputeKernel;
use crate::gpu::{Access, BindingKind, Cmd, Gpu, Image, Write};
use std::sync::Arc;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    width: u32,
    height: u32,
    /// Pairs of (total, global) images: 1 at full resolution, 2 when subsampled.
    pairs: u32,
    pad: u32,
}

pub struct SupportPass {
    kernel: ComputeKernel,
    pairs: u32,
}

impl SupportPass {
    /// The pass over `totals` (the photon volumes' targets) and `globals` (their global
    /// photons' share, the first's alpha holding W), one or two of each.
    pub fn new(gpu: &Arc<Gpu>, totals: &[&Image], globals: &[&Image]) -> anyhow::Result<Self> {
        anyhow::ensure!(
            totals.len() == globals.len() && (1..=2).contains(&totals.len()),
            "support normalisation takes one or two pairs of images"
        );
        // One pair binds it twice; the shader reads the second only with two pairs.
        let second = totals.len() - 1;
        let kernel = ComputeKernel::new(
            gpu,
            "support",
            &crate::gpu::shader_table::SUPPORT_COMP,
            &[BindingKind::StorageImage; 4],
            size_of::<Push>() as u32,
            &[
                Write::StorageImage(totals[0]),
                Write::StorageImage(globals[0]),
                Write::StorageImage(totals[second]),
                Write::StorageImage(globals[second]),
            ],
            &[],
        )?;
        Ok(Self {
            kernel,
            pairs: totals.len() as u32,
        })
    }

    pub fn record(&self, cmd: &Cmd, totals: &[&Image], globals: &[&Image]) {
        let _scope = cmd.scope("support");
        for image in totals.iter().chain(globals) {
            cmd.transition(image, Access::ComputeStorageWrite);
        }
        let (width, height) = (totals[0].width, totals[0].height);
        let push = Push {
            width,
            height,
            pairs: self.pairs,
            pad: 0,
        };
        self.kernel
            .dispatch_with(cmd, &push, super::image_groups(width, height));
    }
}
