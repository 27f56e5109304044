//! The bounce map's texels on the CPU, each a twin of `bounce_map.comp` bit for bit: a light's
//! seed, a texel's random-number key, where in the texel its photon passes and whether it is
//! kept (module docs, "Budget"); and a texel's point in NDC, unprojected onto the light view's
//! near and far planes.

use super::BouncePlan;
use crate::layout::shared_constants::{
    BOUNCE_VIEW_CAUSTIC, JITTER_R2_X, JITTER_R2_Y, JITTER_STREAM_X, JITTER_STREAM_Y, KEEP_R1,
    KEEP_STREAM, LIGHT_VIEW_FAR_Z, LIGHT_VIEW_NEAR_Z,
};
use crate::photon::rng::hash2;
use glam::{DMat4, DVec2, DVec3, DVec4, Vec4};

/// Salt of a light's bounce-map seed ([`light_seed`]).
const LIGHT_SEED_STREAM: u32 = 0x6c1e_5eed;

/// Depth of a light view's near and far planes (reversed: `plan/lighting.rs`).
pub(super) const NEAR: f64 = LIGHT_VIEW_NEAR_Z as f64;
pub(super) const FAR: f64 = LIGHT_VIEW_FAR_Z as f64;

pub(super) fn unproject(inverse: &DMat4, ndc: DVec2, z: f64) -> DVec3 {
    let h = *inverse * DVec4::new(ndc.x, ndc.y, z, 1.0);
    h.truncate() / h.w
}

/// NDC of the centre of texel (x, y) of a `width`×`height` view (row 0 at NDC y = −1, as
/// Vulkan).
pub(super) fn texel_ndc(x: u32, y: u32, width: u32, height: u32) -> DVec2 {
    DVec2::new(
        (f64::from(x) + 0.5) / f64::from(width) * 2.0 - 1.0,
        (f64::from(y) + 0.5) / f64::from(height) * 2.0 - 1.0,
    )
}

/// Where inside texel (`x`, `y`) the photon of sample `sample` passes, in texels from its
/// corner, each in [0, 1): the twin of `texel_jitter` in `bounce_map.comp`. A random offset per
/// texel (two hashes of its `key`, [`BouncePlan::texel_key`]) rotated by point `sample` of the R2
/// sequence (Cranley–Patterson rotation), all in 32-bit fixed point so both sides compute the
/// same bits: within a frame every texel has its own offset, so the photons are stratified and
/// jittered over the view (no lattice in a caustic), and over the frames of an accumulation
/// each texel's offsets are a low-discrepancy sequence (`shared_constants.rs`, `JITTER_*`).
pub fn texel_jitter(key: u32, sample: u32) -> DVec2 {
    let fixed = |stream: u32, step: u32| {
        let bits = hash2(key, stream).wrapping_add(sample.wrapping_mul(step));
        // The top 24 bits, as the GLSL side takes them: exact in f32.
        f64::from(bits >> 8) * (1.0 / 16_777_216.0)
    };
    DVec2::new(
        fixed(JITTER_STREAM_X, JITTER_R2_X),
        fixed(JITTER_STREAM_Y, JITTER_R2_Y),
    )
}

/// Whether the texel whose key is `key` sends its photon in sample `sample` when the view keeps
/// texels with probability `keep`: the twin of `texel_kept` in `bounce_map.comp`, bit for bit (a
/// 24-bit fixed-point number, exact in f32, against `keep` as f32). A probability of 1 keeps
/// every texel.
pub fn texel_kept(key: u32, sample: u32, keep: f32) -> bool {
    let bits = hash2(key, KEEP_STREAM).wrapping_add(sample.wrapping_mul(KEEP_R1));
    ((bits >> 8) as f32) * (1.0 / 16_777_216.0) < keep
}

/// NDC of the point `jitter` (texels from the corner, in [0, 1)) of texel (x, y) of a
/// `width`×`height` view.
pub(super) fn jittered_ndc(x: u32, y: u32, jitter: DVec2, width: u32, height: u32) -> DVec2 {
    DVec2::new(
        (f64::from(x) + jitter.x) / f64::from(width) * 2.0 - 1.0,
        (f64::from(y) + jitter.y) / f64::from(height) * 2.0 - 1.0,
    )
}

impl BouncePlan {
    /// The random-number key of texel (`x`, `y`) of view `v`, the twin of `texel_key` in
    /// `bounce_map.comp`: its light's seed ([`light_seed`]), which of the light's views it is
    /// (`kind.w`) and its texel in that view's grid, a caustic view's counted in its parent's
    /// grid subdivided k × k. Temporal case: none of it changes as a light moves slowly, not
    /// the views before it in the bounce map (their sizes) nor where a caustic window lies, so
    /// each texel keeps its random numbers and its photon moves with the light.
    pub fn texel_key(&self, v: usize, x: u32, y: u32) -> u32 {
        let view = &self.views[v];
        let (mut gx, mut gy) = (x, y);
        if view.kind.y == BOUNCE_VIEW_CAUSTIC {
            // The window's corner in sub-texels of the parent's plane.
            let parent = &self.views[view.kind.z as usize];
            let zw = |p: Vec4| glam::Vec2::new(p.z, p.w);
            let corner = (zw(view.params) - zw(parent.params)) / view.params.x;
            gx = gx.wrapping_add(corner.x.round() as i32 as u32);
            gy = gy.wrapping_add(corner.y.round() as i32 as u32);
        }
        hash2(hash2(hash2(view.texels.w, view.kind.w), gx), gy)
    }
}

/// The bounce-map seed of light `index` of `lights`: a hash of its name and of how many lights
/// before it share the name. Not of its position, so a moving light keeps its texels' random
/// numbers (temporal stability, docs/stability.md); not of its index, so removing another light
/// leaves its photons as they were (`tests/effects_plan.rs`, the enclosed lamp).
pub fn light_seed(lights: &[crate::scene::Light], index: usize) -> u32 {
    let name = &lights[index].name;
    let twins = lights[..index].iter().filter(|l| &l.name == name).count();
    let h = name
        .bytes()
        .fold(LIGHT_SEED_STREAM, |h, b| hash2(h, u32::from(b)));
    hash2(h, twins as u32)
}
