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
//! ([`SceneBvh::intersect_skipping`]), and gathers at the first opaque surface with the
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
use crate::scene::{Material, Scene};
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
        (centres.iter())
            .map(|&centre| {
                indirect_cube(
                    &self.scene,
                    &self.bvh,
                    &gather,
                    relative(centre),
                    kernel.gather_exponent_max(),
                )
            })
            .collect()
    }
}

/// [`PhotonFrame::environment_indirect`] from `gather` (positions in `bvh`'s space, as
/// `centre`), glossy lobes evaluated at exponents of at most `gather_exponent_max`.
pub fn indirect_cube(
    scene: &Scene,
    bvh: &SceneBvh,
    gather: &GatherMap,
    centre: Vec3,
    gather_exponent_max: f32,
) -> Vec<[f32; 4]> {
    let n = FACE_SIZE;
    let delta = delta_instances(scene);
    (0..6 * n * n)
        .into_par_iter()
        .map(|i| {
            let (face, y, x) = ((i / (n * n)) as usize, (i / n) % n, i % n);
            let dir = texel_direction(face, x, y, n);
            let l = radiance_from(
                scene,
                bvh,
                gather,
                &delta,
                Ray::new(centre, dir),
                gather_exponent_max,
            );
            [l.x, l.y, l.z, 1.0]
        })
        .collect()
}

/// The photons' radiance along `ray`, reversed, from its first opaque surface.
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

/// For each of `scene`'s instances, whether its material has a delta lobe (glass, mirrors):
/// the instances an environment cube leaves out (as `Scene::delta_instance_bounds` picks
/// them).
fn delta_instances(scene: &Scene) -> Vec<bool> {
    (scene.instances.iter())
        .map(|inst| {
            (scene.materials.get(scene.meshes[inst.mesh].material))
                .is_some_and(Material::has_delta_lobe)
        })
        .collect()
}
