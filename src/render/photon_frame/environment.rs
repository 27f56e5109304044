//! The photons' indirect light as glass and mirrors see it: a small cube map of the radiance
//! that the photon map reflects towards an environment probe's centre, one per probe
//! (`plan/probes.rs`), gathered on the CPU from
//! each traced photon map and added by the translucent pass to the cached cube of direct light
//! (`passes/environment.rs`, `translucent.frag`).
//!
//! ```text
//!   centre ──ray through texel (face, x, y), glass and mirrors left out──► first hit s
//!                                                                      L = Σ f(s, ωi, ωo)·Φ·κ
//! ```
//!
//! Each texel's ray leaves from the probe's centre, with the delta-material instances left out
//! of the scene as the environment pass leaves them out of the cube it draws
//! ([`SceneBvh::intersect_skipping`]; a material with a delta lobe is left out even when it
//! has a diffuse layer too, as there), and gathers at the first surface it meets with the
//! photon volumes' estimate, seen from the centre instead of the eye: the same photons, kNN
//! radii, kernel and regularised BSDF (`reference::gather::GatherMap`). Not carried over: the
//! pixel-footprint floor (it belongs to the eye's pixels; without it the cube does not depend
//! on the camera), the support normalisation at creases and the same-surface rule for global
//! photons (`passes/support.rs`), so the cube is somewhat dark in corners. Without the cube the
//! glass and mirrors reflected direct light only: inside `cornell-box`'s glass ball ISPM gave
//! 0.46 of the CPU photon gather's radiance, 1.08 with it (docs/accuracy.md §7). The cube is
//! small ([`FACE_SIZE`]² texels a face, sampled bilinearly): indirect light is smooth, and
//! each frame's cube is a new estimate, so its noise averages out with the frames like the rest
//! of the picture.

use super::PhotonFrame;
use crate::passes::environment::texel_direction;
use crate::photon::bvh::SceneBvh;
use crate::photon::kernel::KernelSettings;
use crate::photon::ray::Ray;
use crate::photon::trace::{bsdf_at, PhotonMap};
use crate::reference::gather::GatherMap;
use crate::scene::Scene;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// Texels per side of a face of the indirect cube. 16 would make the cube 4× cheaper (it is
/// 2.5 ms of the default 14 ms frame on an H100), but the metal ring of `caustic-ring` reflects
/// the cube directly: at 640×480, 10k photons, its relMSE went 0.0345 → 0.0477 (cornell-box
/// 0.0122 → 0.0116, glass-sphere 0.0121 → 0.0121; lavapipe, 2026-11-27).
pub const FACE_SIZE: u32 = 32;

impl PhotonFrame {
    /// The indirect cube of each environment probe centred at `centres` (world space): RGBA
    /// (alpha 1) per texel, face after face (+X, −X, +Y, −Y, +Z, −Z), rows from the top.
    /// Zeros when the photon map is empty.
    pub fn environment_indirect(&self, centres: &[DVec3]) -> Vec<Vec<[f32; 4]>> {
        let texels = (6 * FACE_SIZE * FACE_SIZE) as usize;
        if self.radii.is_empty() || centres.is_empty() {
            return vec![vec![[0.0, 0.0, 0.0, 1.0]; texels]; centres.len()];
        }
        let map = PhotonMap {
            photons: self.traced.photons().copied().collect(),
            ..Default::default()
        };
        // Photons, BVH and the centres relative to the plan's origin (module docs of
        // `photon_frame`); no footprint floor (module docs), so the radii do not depend on the
        // viewpoint and one gather map serves every probe.
        let relative = |c: DVec3| (c - self.plan.origin).as_vec3();
        let kernel = KernelSettings {
            footprint: 0.0,
            ..self.kernel_clamp
        };
        let gather = GatherMap::with_knn_radii(map, &self.radii, &kernel, relative(centres[0]));
        let delta = self.scene.delta_instance_mask();
        (centres.iter())
            .map(|&centre| {
                indirect_cube(
                    &self.scene,
                    &self.bvh,
                    &gather,
                    &delta,
                    relative(centre),
                    kernel.gather_exponent_max(),
                )
            })
            .collect()
    }
}

/// [`PhotonFrame::environment_indirect`] from `gather` (positions in `bvh`'s space, as
/// `centre`), glossy lobes evaluated at exponents of at most `gather_exponent_max`, the
/// instances `delta` marks ([`Scene::delta_instance_mask`]) left out.
pub fn indirect_cube(
    scene: &Scene,
    bvh: &SceneBvh,
    gather: &GatherMap,
    delta: &[bool],
    centre: Vec3,
    gather_exponent_max: f32,
) -> Vec<[f32; 4]> {
    let n = FACE_SIZE;
    (0..6 * n * n)
        .into_par_iter()
        .map(|i| {
            let (face, y, x) = ((i / (n * n)) as usize, (i / n) % n, i % n);
            let dir = texel_direction(face, x, y, n);
            let l = radiance_from(
                scene,
                bvh,
                gather,
                delta,
                Ray::new(centre, dir),
                gather_exponent_max,
            );
            [l.x, l.y, l.z, 1.0]
        })
        .collect()
}

/// The photons' radiance along `ray`, reversed, from its first surface that `delta` does not
/// mark.
fn radiance_from(
    scene: &Scene,
    bvh: &SceneBvh,
    gather: &GatherMap,
    delta: &[bool],
    ray: Ray,
    gather_exponent_max: f32,
) -> Vec3 {
    let Some(hit) = bvh.intersect_skipping(&ray, delta) else {
        return Vec3::ZERO;
    };
    let bsdf = bsdf_at(scene, &hit).regularized(gather_exponent_max);
    let l = gather.radiance(&hit, &bsdf, -ray.dir);
    if l.is_finite() {
        l.max(Vec3::ZERO)
    } else {
        Vec3::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::types::Photon;

    /// The bundled `glass-cube`'s cube rests on the floor (its bottom face and the floor are
    /// one plane). Every texel of its probe's −Y face looks from the cube's centre down through
    /// the bottom face onto the floor under the cube, within 45° of straight down: with photons
    /// all over the floor, none of them may be black. Passing through the glass instead (a
    /// new ray spawned past each glass hit, which starts past the floor's plane too) left 827
    /// of the 1024 black: the blocky top face of docs/accuracy.md.
    #[test]
    fn a_probe_in_glass_standing_on_a_floor_sees_the_floor_in_every_texel_below() {
        let scene = crate::scene::bundled::resolve(Some("glass-cube")).expect("bundled scene");
        let bvh = SceneBvh::new(&scene);
        let delta = scene.delta_instance_mask();
        let (cube, bounds) = scene
            .delta_instance_bounds()
            .into_iter()
            .find(|&(i, _)| scene.meshes[scene.instances[i].mesh].triangles.len() == 12)
            .expect("the 12-triangle cube");
        assert!(delta[cube] && bounds.min.y.abs() < 1e-6, "{bounds:?}");
        // Photons on a 2 cm grid over the 2 m floor, arriving from above.
        let photons: Vec<Photon> = (0..100 * 100)
            .map(|i| {
                let p = Vec3::new((i % 100) as f32, 0.0, (i / 100) as f32) * 0.02
                    - Vec3::new(0.99, 0.0, 0.99);
                Photon::new(Vec3::splat(1e-4), Vec3::Y, 1.0, p, Vec3::Y)
            })
            .collect();
        let knn = vec![0.03; photons.len()];
        let map = PhotonMap {
            photons,
            ..Default::default()
        };
        let kernel = KernelSettings::scene_relative(&scene.bounds(), 10_000, Some(0.1));
        let centre = bounds.center();
        let gather = GatherMap::with_knn_radii(map, &knn, &kernel, centre);
        let cube = indirect_cube(
            &scene,
            &bvh,
            &gather,
            &delta,
            centre,
            kernel.gather_exponent_max(),
        );
        let n = (FACE_SIZE * FACE_SIZE) as usize;
        let below = &cube[3 * n..4 * n]; // −Y
        let black = below.iter().filter(|t| t[0] <= 0.0).count();
        assert_eq!(black, 0, "{black} of {n} texels below the probe are black");
        let lo = below.iter().map(|t| t[0]).fold(f32::INFINITY, f32::min);
        let hi = below.iter().map(|t| t[0]).fold(0.0, f32::max);
        assert!(
            hi < 2.0 * lo,
            "the floor under the cube is evenly lit: {lo} to {hi}"
        );
    }
}
