//! Caustic photons for the CPU photon mappers (`progressive`, `photon-gather`): part of each
//! photon map aimed at the surfaces with a delta lobe (mirrors, glass), the rest emitted as
//! usual, the light paths split between the two by where their first ray lands, so that
//! nothing is counted twice or left out.
//!
//! ```text
//!   light ──► first ray hits a delta surface?  ──yes──► paths of the aimed photons
//!                                              ──no───► paths of the usual photons
//! ```
//!
//! *Why.* Emitted over the whole scene, few photons reach a small mirror or glass object:
//! `caustic-ring`'s sun puts about 1 % of them on the ring, so a 100k-photon iteration draws
//! the cardioid with about a thousand photons and the reference was either blurred (one
//! global radius, 5 cm after 256 iterations) or noisy there. ISPM's GPU bounce map solves the
//! same problem with caustic views (`plan::bounce_plan`); this is the CPU reference's twin,
//! Jensen's projection maps in their simplest form: a sphere round all delta surfaces.
//!
//! *Unbiased.* For a light with aimed photons ([`emit_toward`]), every ray that can hit a
//! delta surface passes through the sphere, so the aimed photons cover all of those paths
//! (each carrying the flux through the sphere over their count), and the usual photons keep
//! only paths whose first ray lands elsewhere (or nowhere): each light path is estimated by
//! exactly one of the two. A light that cannot be aimed (an emitter's area sample, a point or
//! spot light inside the sphere) keeps all its usual paths. The tests below check that the
//! split leaves the stored power of caustic and global photons where the usual emission puts
//! it, for a sun, a point light and two spot lights.
//!
//! *What it costs.* At the same photon count the paths that do not start on a delta surface
//! (most of the global light) get half the photons, so their noise grows by about √2 per map;
//! and a usual photon that reaches a caustic another way (floor → mirror → floor) carries more
//! power than the aimed photons round it (15× on `caustic-ring`), with a kernel sized by their
//! density: variance, not bias. A spot light is aimed at the whole cone towards the sphere,
//! including the directions its own cone leaves dark, whose photons carry no power (dropped by
//! the tracer); its share of the aimed photons follows its falloff-weighted flux through that
//! cone ([`flux_toward`]), so a spot pointing away from the sphere gets none. Every photon's
//! first ray is cast here to split the paths and again by the tracer: one extra ray per
//! emitted photon, against the two or more a traced path costs.

use crate::photon::bvh::SceneBvh;
use crate::photon::emit::{emit_photons, emit_toward, flux_toward, EmittedPhoton, Target};
use crate::photon::ray::Ray;
use crate::photon::rng::hash2;
use crate::scene::{Aabb, Scene};
use rayon::prelude::*;

/// The share of each progressive iteration's photons aimed at the delta surfaces, when the
/// scene has any and a light can be aimed at them (the same half ISPM's caustic views get by
/// default, `config::settings::CAUSTIC_SHARE`).
pub const CAUSTIC_SHARE: f32 = 0.5;

/// The sphere round every triangle whose material has a delta lobe (`None` without any).
pub fn delta_target(scene: &Scene) -> Option<Target> {
    let mut bounds = Aabb::EMPTY;
    for (triangle, material) in scene.world_triangles() {
        if scene.materials[material].has_delta_lobe() {
            triangle.into_iter().for_each(|p| bounds.grow(p));
        }
    }
    Target::of(&bounds)
}

/// About `photons` photons for one photon map, `share` of them aimed at `target` (module
/// docs), with every photon's first ray already tested: the usual photons whose light is aimed
/// and whose first ray hits a delta surface are left out, and so are the aimed photons whose
/// first ray does not.
pub fn split_emission(
    scene: &Scene,
    bvh: &SceneBvh,
    photons: usize,
    seed: u32,
    target: Option<&Target>,
    share: f32,
) -> Vec<EmittedPhoton> {
    let Some(target) = target.filter(|_| share > 0.0) else {
        return emit_photons(scene, photons, seed);
    };
    let flux: Vec<f32> = scene
        .lights
        .iter()
        .map(|l| flux_toward(l, target).element_sum())
        .collect();
    let total: f32 = flux.iter().sum();
    if !(total > 0.0 && total.is_finite()) {
        return emit_photons(scene, photons, seed);
    }
    let aimed_total = ((photons as f32) * share.clamp(0.0, 1.0)).round() as usize;
    let aimed: Vec<Vec<EmittedPhoton>> = flux
        .iter()
        .enumerate()
        .map(|(i, f)| {
            let count = ((aimed_total as f32) * f / total).round() as usize;
            emit_toward(scene, i, count, hash2(seed, AIMED_STREAM), target)
        })
        .collect();
    let is_aimed: Vec<bool> = aimed.iter().map(|a| !a.is_empty()).collect();
    let aimed_count: usize = aimed.iter().map(Vec::len).sum();
    let first_hits_delta = |p: &EmittedPhoton| {
        bvh.intersect(&Ray::new(p.origin, p.direction))
            .is_some_and(|hit| scene.materials[hit.material].has_delta_lobe())
    };
    let usual = emit_photons(scene, photons.saturating_sub(aimed_count), seed);
    let mut out: Vec<EmittedPhoton> = usual
        .into_par_iter()
        .filter(|p| {
            !is_aimed.get(p.light as usize).copied().unwrap_or(false) || !first_hits_delta(p)
        })
        .collect();
    out.par_extend(
        aimed
            .into_par_iter()
            .flatten()
            .filter(|p| first_hits_delta(p)),
    );
    out
}

/// The random stream of the aimed photons, apart from the usual photons' of the same seed.
const AIMED_STREAM: u32 = 0xca05_71c5;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::density::PhotonClass;
    use crate::photon::trace::{trace_from_lights, TraceSettings};
    use glam::Vec3;

    /// Stored photons' power by class (caustic, global) and the caustic photons' count.
    fn stored(scene: &Scene, bvh: &SceneBvh, emitted: &[EmittedPhoton]) -> (Vec3, Vec3, usize) {
        let settings = TraceSettings {
            max_bounces: 8,
            seed: 5,
            ..Default::default()
        };
        let map = trace_from_lights(scene, bvh, emitted, &settings);
        let (mut caustic, mut global, mut count) = (Vec3::ZERO, Vec3::ZERO, 0);
        for p in &map.photons {
            match PhotonClass::of_photon(p) {
                PhotonClass::Caustic => {
                    caustic += p.power;
                    count += 1;
                }
                PhotonClass::Global => global += p.power,
            }
        }
        (caustic, global, count)
    }

    /// The bundled `caustic-ring` with its sun replaced by a point light 1.2 m beside the ring
    /// and 0.8 m up: the cone-aimed case.
    fn ring_under_a_point_light() -> Scene {
        let mut scene = crate::scene::bundled::resolve(Some("caustic-ring")).expect("bundled");
        let light = &mut scene.lights[0];
        light.kind = crate::scene::LightKind::Point;
        light.position = Vec3::new(1.2, 0.8, 0.3);
        light.intensity = Vec3::splat(2.0);
        scene
    }

    /// The split moves photons onto the mirrors and the glass without moving light, over three
    /// seeds against the usual emission with four times the photons: the power stored by
    /// caustic photons within 4 % and by global photons within 10 % (a few rare paths carry
    /// it: glass-sphere's floor → ball → floor, 0.87–1.02 per seed), on `caustic-ring` (a sun
    /// aimed at a disk), the same ring under a point light (a cone), `glass-sphere` (a spot) and
    /// `cornell-box` (two spots, a glass and a mirror ball: the budget split between lights);
    /// and it stores more caustic photons per emitted photon: 7.4× on caustic-ring, 2× on
    /// glass-sphere, whose spot already points at the ball.
    #[test]
    fn aimed_photons_keep_the_stored_power_and_multiply_the_caustic_photons() {
        let bundled = |name| crate::scene::bundled::resolve(Some(name)).expect("bundled scene");
        let cases = [
            ("caustic-ring", bundled("caustic-ring"), 5.0),
            ("caustic-ring, point light", ring_under_a_point_light(), 3.0),
            ("glass-sphere", bundled("glass-sphere"), 1.5),
            ("cornell-box", bundled("cornell-box"), 1.2),
        ];
        for (name, scene, gain) in cases {
            let bvh = SceneBvh::new(&scene);
            let target = delta_target(&scene).expect("a delta surface");
            let n = 100_000;
            let (mut usual, mut split) = ((Vec3::ZERO, Vec3::ZERO, 0), (Vec3::ZERO, Vec3::ZERO, 0));
            for seed in 11..14 {
                let sum = |a: (Vec3, Vec3, usize), b: (Vec3, Vec3, usize)| {
                    (a.0 + b.0, a.1 + b.1, a.2 + b.2)
                };
                usual = sum(
                    usual,
                    stored(&scene, &bvh, &emit_photons(&scene, 4 * n, seed)),
                );
                let emitted = split_emission(&scene, &bvh, n, seed, Some(&target), CAUSTIC_SHARE);
                split = sum(split, stored(&scene, &bvh, &emitted));
            }
            let ratio = |a: Vec3, b: Vec3| a.element_sum() / b.element_sum();
            let (caustic, global) = (ratio(split.0, usual.0), ratio(split.1, usual.1));
            let gained = split.2 as f64 / (usual.2 as f64 / 4.0);
            eprintln!(
                "{name}: split / usual stored power: caustic {caustic:.4}, global {global:.4}; \
                 caustic photons per emitted photon {gained:.2}×"
            );
            assert!(
                (caustic - 1.0).abs() < 0.04,
                "{name}: caustic power moved: {caustic:.4}"
            );
            if usual.1.element_sum() > 0.0 {
                assert!(
                    (global - 1.0).abs() < 0.10,
                    "{name}: global power moved: {global:.4}"
                );
            }
            assert!(
                gained >= gain,
                "{name}: only {gained:.2}× the caustic photons"
            );
        }
    }

    /// Photons aimed at a sphere a light cannot reach carry nothing: a spot turned away from
    /// the ring has no flux towards it, and the split emits as usual for it.
    #[test]
    fn a_spot_turned_away_from_the_target_is_not_aimed() {
        let mut scene = ring_under_a_point_light();
        let light = &mut scene.lights[0];
        light.kind = crate::scene::LightKind::Spot {
            inner_cone_angle: 0.2,
            outer_cone_angle: 0.3,
        };
        light.direction = Vec3::X; // away from the ring at the origin
        let target = delta_target(&scene).expect("a delta surface");
        assert_eq!(flux_toward(&scene.lights[0], &target), Vec3::ZERO);
        let bvh = SceneBvh::new(&scene);
        assert_eq!(
            split_emission(&scene, &bvh, 1000, 3, Some(&target), CAUSTIC_SHARE),
            emit_photons(&scene, 1000, 3)
        );
        // Turned towards it, it is aimed.
        scene.lights[0].direction = -scene.lights[0].position.normalize();
        assert!(flux_toward(&scene.lights[0], &target).element_sum() > 0.0);
    }

    /// Without a delta surface, or with no share, the split is the usual emission.
    #[test]
    fn no_target_or_no_share_emits_as_usual() {
        let scene = crate::scene::bundled::resolve(Some("diffuse-box")).expect("bundled scene");
        let bvh = SceneBvh::new(&scene);
        assert_eq!(delta_target(&scene), None);
        let usual = emit_photons(&scene, 1000, 3);
        assert_eq!(
            split_emission(&scene, &bvh, 1000, 3, None, CAUSTIC_SHARE),
            usual
        );
        let ring = crate::scene::bundled::resolve(Some("caustic-ring")).expect("bundled scene");
        let ring_bvh = SceneBvh::new(&ring);
        let target = delta_target(&ring);
        assert_eq!(
            split_emission(&ring, &ring_bvh, 1000, 3, target.as_ref(), 0.0),
            emit_photons(&ring, 1000, 3)
        );
    }
}
