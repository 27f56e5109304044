//! Photon emission from punctual lights on the CPU (DESIGN.md §2.3): the reference renderers
//! emit with it, and it is the CPU twin of the GPU bounce map's emission.
//!
//! - **Point**: directions uniform on the sphere, flux `Φ = 4π·I`.
//! - **Spot**: directions importance-sampled from the KHR_lights_punctual falloff inside the
//!   outer cone (`cos θ` drawn from a pdf ∝ falloff, φ uniform), so every photon carries the same
//!   power; `Φ = 2π·I·∫ falloff(cos θ) d cos θ` in closed form ([`spot_falloff_integral`]).
//! - **Directional**: origins uniform on the disk perpendicular to the direction that covers
//!   the scene's bounding sphere, placed just outside it; `Φ = E·π R²`.
//!
//! Budget: light L gets `N·Φ̄_L/Φ̄_total` photons (Φ̄: mean of RGB) rounded so that the lights'
//! budgets sum to `N` exactly (largest remainders round up), each carrying
//! `Φ_L / N_L`, so a light's photon powers sum to its flux exactly (up to float rounding),
//! whatever the rounding of the budget.
//!
//! Random numbers: photon `i` of light `l` draws from `Rng::new(seed)` with
//! `seed = seed_bounce_map_texel(light.position, i, hash2(global_seed, l))`; the photon keeps
//! that seed so that the first bounce ([`super::trace::first_bounce`]) is reproducible too.

use super::rng::{hash2, seed_bounce_map_texel, Rng};
use super::sampling::{concentric_disk, cosine_hemisphere, uniform_sphere, Frame};
use crate::layout::shared_constants::{LIGHT_AREA_SAMPLE, LIGHT_SPOT};
use crate::scene::emitters::Emitters;
use crate::scene::{Aabb, Light, LightKind, Scene};
use glam::Vec3;
use std::f32::consts::{PI, TAU};

/// A photon leaving a light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmittedPhoton {
    pub origin: Vec3,
    /// Unit direction of travel.
    pub direction: Vec3,
    /// Power Φ (W, linear RGB).
    pub power: Vec3,
    /// Index into `Scene::lights`.
    pub light: u32,
    /// The photon's RNG seed (emission, then the first bounce).
    pub seed: u32,
}

/// KHR_lights_punctual spot falloff (as `glsl/common/lights.glsl`): `clamp((cd − cos_o)·s)²`
/// with `s = 1/max(10⁻⁴, cos_i − cos_o)`.
pub fn spot_falloff(cos_inner: f32, cos_outer: f32, cd: f32) -> f32 {
    let scale = 1.0 / (cos_inner - cos_outer).max(1e-4);
    let t = ((cd - cos_outer) * scale).clamp(0.0, 1.0);
    t * t
}

/// How a light of GPU kind `kind` (`LIGHT_*`) falls off with `cd`, the cosine between its axis
/// and the direction to the point: the spot cone, `max(0, cd)` for an emitter's area sample, 1
/// otherwise (the twin of `light_falloff` in `glsl/common/lights.glsl`).
pub fn light_falloff(kind: u32, cos_inner: f32, cos_outer: f32, cd: f32) -> f32 {
    match kind {
        LIGHT_SPOT => spot_falloff(cos_inner, cos_outer, cd),
        LIGHT_AREA_SAMPLE => cd.max(0.0),
        _ => 1.0,
    }
}

/// `∫_{cos_o}^{1} falloff(c) dc` in closed form, for cone angles in radians (computed in
/// `f64` with `1 − cos θ = 2 sin²(θ/2)`, exact for narrow cones too).
pub fn spot_falloff_integral(inner_cone_angle: f32, outer_cone_angle: f32) -> f32 {
    let (inner, outer) = (inner_cone_angle as f64, outer_cone_angle as f64);
    let width = (inner.cos() - outer.cos()).max(1e-4);
    let one_minus_cos_outer = 2.0 * (0.5 * outer).sin().powi(2);
    let plateau = one_minus_cos_outer - width;
    let integral = if plateau >= 0.0 {
        width / 3.0 + plateau
    } else {
        let u = one_minus_cos_outer / width;
        width * u * u * u / 3.0
    };
    integral as f32
}

/// Samples `cos θ` in `[cos_o, 1]` with pdf ∝ falloff.
fn sample_spot_cos(inner_cone_angle: f32, outer_cone_angle: f32, u: f32) -> f32 {
    let (cos_inner, cos_outer) = (inner_cone_angle.cos(), outer_cone_angle.cos());
    let width = (cos_inner - cos_outer).max(1e-4);
    let total = spot_falloff_integral(inner_cone_angle, outer_cone_angle);
    let x = u * total;
    let ramp_mass = (width / 3.0).min(total);
    if x < ramp_mass {
        // ∫₀^c' (c/w)² dc = c'³/(3w²) = x  ⇒  c' = (3 x w²)^(1/3).
        let c = (3.0 * x * width * width).cbrt();
        (cos_outer + c).min(1.0)
    } else {
        (cos_outer + width + (x - ramp_mass)).min(1.0)
    }
}

/// Centre and radius of the bounding sphere of `bounds` (unit sphere at the origin if empty).
fn bounding_sphere(bounds: &Aabb) -> (Vec3, f32) {
    if bounds.is_empty() {
        (Vec3::ZERO, 1.0)
    } else {
        (bounds.center(), (bounds.extent().length() * 0.5).max(1e-6))
    }
}

fn sanitize(v: Vec3) -> Vec3 {
    Vec3::from_array(
        v.to_array()
            .map(|c| if c.is_finite() { c.max(0.0) } else { 0.0 }),
    )
}

/// The light's flux Φ (W, RGB); `scene_bounds` sizes a directional light's disk.
pub fn light_flux(light: &Light, scene_bounds: &Aabb) -> Vec3 {
    let intensity = sanitize(light.intensity);
    match light.kind {
        LightKind::Point => intensity * (4.0 * PI),
        LightKind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } => intensity * (TAU * spot_falloff_integral(inner_cone_angle, outer_cone_angle)),
        LightKind::Directional => {
            let (_, r) = bounding_sphere(scene_bounds);
            intensity * (PI * r * r)
        }
        // ∫ I·max(0, cos θ) dω = π·I.
        LightKind::AreaSample => intensity * PI,
    }
}

fn mean(v: Vec3) -> f32 {
    (v.x + v.y + v.z) / 3.0
}

/// How many of `photons` each light emits: ∝ its mean flux, rounded.
pub fn photon_budget(scene: &Scene, photons: usize) -> Vec<usize> {
    photon_budget_among(scene, photons, &vec![true; scene.lights.len()])
}

/// [`photon_budget`] over the lights with `active[i]` only: the others get 0 and their share
/// goes to the active ones, still ∝ mean flux. A light missing from `active` is inactive.
pub fn photon_budget_among(scene: &Scene, photons: usize, active: &[bool]) -> Vec<usize> {
    let bounds = scene.bounds();
    let flux: Vec<f32> = scene
        .lights
        .iter()
        .enumerate()
        .map(|(i, l)| {
            if active.get(i) == Some(&true) {
                mean(light_flux(l, &bounds))
            } else {
                0.0
            }
        })
        .collect();
    let total: f32 = flux.iter().sum();
    if !(total > 0.0 && total.is_finite()) {
        return vec![0; scene.lights.len()];
    }
    // Hard case "hundreds of lights": rounding each share on its own misses the total by up
    // to half a photon per light; the largest remainders get the photons left over instead.
    let exact: Vec<f64> = flux
        .iter()
        .map(|f| (photons as f64) * f64::from(*f) / f64::from(total))
        .collect();
    let mut budget: Vec<usize> = exact.iter().map(|e| e.floor() as usize).collect();
    let left = photons.saturating_sub(budget.iter().sum());
    let mut order: Vec<usize> = (0..exact.len()).filter(|&i| exact[i] > 0.0).collect();
    order.sort_by(|&a, &b| {
        let rem = |i: usize| exact[i] - exact[i].floor();
        rem(b).total_cmp(&rem(a)).then(a.cmp(&b))
    });
    for &i in order.iter().take(left) {
        budget[i] += 1;
    }
    budget
}

/// One photon of `light`, drawn with `rng`, carrying `power`.
fn emit_one(light: &Light, bounds: &Aabb, rng: &mut Rng) -> (Vec3, Vec3) {
    match light.kind {
        LightKind::Point => (light.position, uniform_sphere(rng.next_2())),
        LightKind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } => {
            let cos_t = sample_spot_cos(inner_cone_angle, outer_cone_angle, rng.next_f32());
            let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
            let phi = TAU * rng.next_f32();
            let axis = light.direction.try_normalize().unwrap_or(Vec3::NEG_Z);
            let local = Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t);
            (light.position, Frame::from_normal(axis).to_world(local))
        }
        LightKind::Directional => {
            let (c, r) = bounding_sphere(bounds);
            let dir = light.direction.try_normalize().unwrap_or(Vec3::NEG_Y);
            let disk = concentric_disk(rng.next_2()) * r;
            let frame = Frame::from_normal(dir);
            let origin = c - dir * (r * 1.01) + frame.to_world(Vec3::new(disk.x, disk.y, 0.0));
            (origin, dir)
        }
        LightKind::AreaSample => {
            let normal = light.direction.try_normalize().unwrap_or(Vec3::NEG_Y);
            let local = cosine_hemisphere(rng.next_2());
            (light.position, Frame::from_normal(normal).to_world(local))
        }
    }
}

/// `count` photons of light `index`, whose powers sum to its flux.
pub fn emit_from_light(
    scene: &Scene,
    index: usize,
    count: usize,
    global_seed: u32,
) -> Vec<EmittedPhoton> {
    let light = &scene.lights[index];
    let bounds = scene.bounds();
    if count == 0 {
        return Vec::new();
    }
    let power = light_flux(light, &bounds) / count as f32;
    photons_of(light, index, count, global_seed, |rng| {
        let (origin, direction) = emit_one(light, &bounds, rng);
        (origin, direction, power)
    })
}

/// `count` photons of light `index`, photon `i` drawn by `draw` (origin, direction, power) from
/// its own RNG, seeded as the module docs say.
fn photons_of(
    light: &Light,
    index: usize,
    count: usize,
    global_seed: u32,
    draw: impl Fn(&mut Rng) -> (Vec3, Vec3, Vec3),
) -> Vec<EmittedPhoton> {
    let light_seed = hash2(global_seed, index as u32);
    (0..count)
        .map(|i| {
            let seed = seed_bounce_map_texel(light.position, i as u32, light_seed);
            let (origin, direction, power) = draw(&mut Rng::new(seed));
            EmittedPhoton {
                origin,
                direction,
                power,
                light: index as u32,
                seed,
            }
        })
        .collect()
}

/// A sphere a light's photons can be aimed at ([`emit_toward`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Target {
    pub center: Vec3,
    pub radius: f32,
}

impl Target {
    /// The bounding sphere of `bounds`, a thousandth wider so that no ray grazing a corner of
    /// the box is lost to rounding (`None` when it is empty).
    pub fn of(bounds: &Aabb) -> Option<Self> {
        (!bounds.is_empty()).then(|| {
            let (center, radius) = bounding_sphere(bounds);
            Self {
                center,
                radius: radius * 1.001,
            }
        })
    }
}

/// The directions (or, for a directional light, the origins) of `light` whose rays can reach
/// `target`, and how to draw them: `None` when the light cannot be aimed (an emitter's area
/// sample, or a point or spot light inside the sphere, whose rays reach it in every direction).
fn aim(light: &Light, target: &Target) -> Option<Aim> {
    match light.kind {
        LightKind::Directional => Some(Aim::Disk),
        LightKind::Point | LightKind::Spot { .. } => {
            let to = target.center - light.position;
            let d = to.length();
            // Inside (or on) the sphere, or a broken position (NaN compares false).
            let outside = d.is_finite() && d > target.radius * 1.0001;
            if !outside {
                return None;
            }
            let sin_max = target.radius / d;
            // 1 − cos θmax = 2 sin²(θmax/2), exact for small spheres far away.
            let half = 0.5 * sin_max.asin();
            let one_minus_cos = 2.0 * half.sin() * half.sin();
            Some(Aim::Cone {
                axis: to / d,
                one_minus_cos,
            })
        }
        LightKind::AreaSample => None,
    }
}

enum Aim {
    /// Origins uniform on the target's disk, across the light's direction.
    Disk,
    /// Directions uniform in the cone round `axis` that holds the sphere.
    Cone { axis: Vec3, one_minus_cos: f32 },
}

/// The flux of `light` through `target`'s disk or cone, what [`emit_toward`]'s photons carry
/// together (in expectation for a spot, whose falloff over the cone is averaged here over a
/// fixed 16 × 16 grid of the cone's directions: zero for a spot that points away from the
/// target). Zero when the light cannot be aimed at it.
pub fn flux_toward(light: &Light, target: &Target) -> Vec3 {
    let intensity = sanitize(light.intensity);
    match aim(light, target) {
        None => Vec3::ZERO,
        Some(Aim::Disk) => intensity * (PI * target.radius * target.radius),
        Some(Aim::Cone {
            axis,
            one_minus_cos,
        }) => {
            const GRID: u32 = 16;
            let mut falloff = 0.0;
            for i in 0..GRID * GRID {
                let u = ((i / GRID) as f32 + 0.5) / GRID as f32;
                let v = ((i % GRID) as f32 + 0.5) / GRID as f32;
                falloff += cone_falloff(light, cone_direction(axis, one_minus_cos, [u, v]));
            }
            intensity * (TAU * one_minus_cos * falloff / (GRID * GRID) as f32)
        }
    }
}

/// A direction uniform over the cone round `axis` of solid angle `2π·one_minus_cos`, from `u`.
fn cone_direction(axis: Vec3, one_minus_cos: f32, [u, v]: [f32; 2]) -> Vec3 {
    let cos_t = 1.0 - u * one_minus_cos;
    let sin_t = (u * one_minus_cos * (1.0 + cos_t)).max(0.0).sqrt();
    let phi = TAU * v;
    let local = Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t);
    Frame::from_normal(axis).to_world(local).normalize()
}

/// The spot's falloff towards `dir` (1 for a point light).
fn cone_falloff(light: &Light, dir: Vec3) -> f32 {
    match light.kind {
        LightKind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } => {
            let spot_axis = light.direction.try_normalize().unwrap_or(Vec3::NEG_Z);
            let (cos_i, cos_o) = (inner_cone_angle.cos(), outer_cone_angle.cos());
            spot_falloff(cos_i, cos_o, dir.dot(spot_axis))
        }
        _ => 1.0,
    }
}

/// `count` photons of light `index` aimed at `target`: for a directional light, origins
/// uniform on the disk across its direction that covers the sphere, started outside the whole
/// scene; for a point or spot light, directions uniform in the cone from the light that holds
/// the sphere, each carrying `I·falloff(ω)·Ω/count` (Ω the cone's solid angle). Every ray of the
/// light that can hit something inside the sphere is among those drawn, so a photon map whose
/// light paths are split by where the first ray lands (these photons for the paths whose first
/// ray hits a surface the sphere was drawn round, the light's own emission for the rest) is an
/// unbiased estimate with many more photons on the target (the CPU references' caustic photons,
/// `reference::caustic_photons`). Empty when the light cannot be aimed at it.
pub fn emit_toward(
    scene: &Scene,
    index: usize,
    count: usize,
    global_seed: u32,
    target: &Target,
) -> Vec<EmittedPhoton> {
    let light = &scene.lights[index];
    let Some(aim) = aim(light, target).filter(|_| count > 0) else {
        return Vec::new();
    };
    let (scene_center, scene_radius) = bounding_sphere(&scene.bounds());
    let intensity = sanitize(light.intensity);
    photons_of(light, index, count, global_seed, |rng| match aim {
        Aim::Disk => {
            let dir = light.direction.try_normalize().unwrap_or(Vec3::NEG_Y);
            let disk = concentric_disk(rng.next_2()) * target.radius;
            let frame = Frame::from_normal(dir);
            // Back along the light's direction until outside the scene's sphere.
            let back = (target.center - scene_center).length() + scene_radius;
            let origin = target.center - dir * (back * 1.01)
                + frame.to_world(Vec3::new(disk.x, disk.y, 0.0));
            let flux = intensity * (PI * target.radius * target.radius);
            (origin, dir, flux / count as f32)
        }
        Aim::Cone {
            axis,
            one_minus_cos,
        } => {
            let dir = cone_direction(axis, one_minus_cos, rng.next_2());
            let falloff = cone_falloff(light, dir);
            let flux = intensity * (TAU * one_minus_cos * falloff);
            (light.position, dir, flux / count as f32)
        }
    })
}

/// About `photons` photons from all lights and emissive surfaces, budgeted by power: the
/// emitters together get `N·Φ̄_e/Φ̄_total` (rounded), the lights the rest ([`photon_budget`]).
pub fn emit_photons(scene: &Scene, photons: usize, global_seed: u32) -> Vec<EmittedPhoton> {
    let emitters = Emitters::of(scene);
    let bounds = scene.bounds();
    let lights: f64 = scene
        .lights
        .iter()
        .map(|l| f64::from(mean(light_flux(l, &bounds))))
        .sum();
    let emitted = f64::from(mean(emitters.flux()));
    let total = lights + emitted;
    let from_emitters = if total > 0.0 && total.is_finite() && !emitters.is_empty() {
        ((photons as f64) * emitted / total).round() as usize
    } else {
        0
    };
    let mut out: Vec<EmittedPhoton> = photon_budget(scene, photons - from_emitters)
        .into_iter()
        .enumerate()
        .flat_map(|(i, n)| emit_from_light(scene, i, n, global_seed))
        .collect();
    out.extend(emit_from_emitters(
        scene,
        &emitters,
        from_emitters,
        global_seed,
    ));
    out
}

/// `count` photons from the emissive surfaces (`scene::emitters`), whose powers sum to their
/// flux in expectation: each starts at a point drawn ∝ power and uniformly by area (a hair in
/// front of its face), in a cosine-distributed direction about the face's normal (a Lambertian
/// emitter), carrying the flux its point stands for over `count`. Their `light` is
/// `scene.lights.len()`.
pub fn emit_from_emitters(
    scene: &Scene,
    emitters: &Emitters,
    count: usize,
    global_seed: u32,
) -> Vec<EmittedPhoton> {
    let stream = hash2(global_seed, EMITTER_STREAM);
    (0..count)
        .filter_map(|i| {
            let seed = hash2(stream, i as u32);
            let mut rng = Rng::new(seed);
            let s = emitters.sample(rng.next_3())?;
            let local = cosine_hemisphere(rng.next_2());
            Some(EmittedPhoton {
                origin: emitters.in_front(s.position, s.normal),
                direction: Frame::from_normal(s.normal).to_world(local),
                power: s.flux / count as f32,
                light: scene.lights.len() as u32,
                seed,
            })
        })
        .collect()
}

/// Salt of the emitters' photon seeds.
const EMITTER_STREAM: u32 = 0x0e31_77e5;

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Mat4;

    fn scene_with(lights: Vec<Light>) -> Scene {
        let mut s = crate::photon::shapes::scene_of(vec![(
            crate::photon::shapes::icosphere(1),
            Mat4::from_scale(Vec3::splat(3.0)),
        )]);
        s.lights = lights;
        s
    }

    fn light(kind: LightKind, intensity: Vec3) -> Light {
        Light {
            name: "l".into(),
            kind,
            position: Vec3::new(0.1, 0.2, 0.3),
            direction: Vec3::new(0.0, -1.0, 0.2).normalize(),
            intensity,
        }
    }

    fn kinds() -> [LightKind; 5] {
        [
            LightKind::AreaSample,
            LightKind::Point,
            LightKind::Spot {
                inner_cone_angle: 0.3,
                outer_cone_angle: 0.7,
            },
            LightKind::Spot {
                inner_cone_angle: 0.0,
                outer_cone_angle: 1e-3,
            },
            LightKind::Directional,
        ]
    }

    #[test]
    fn photon_power_sums_to_light_flux_for_every_light_kind() {
        for kind in kinds() {
            let s = scene_with(vec![light(kind, Vec3::new(1.0, 2.0, 3.5))]);
            let flux = light_flux(&s.lights[0], &s.bounds());
            for n in [1, 7, 1000] {
                let sum = emit_from_light(&s, 0, n, 9)
                    .iter()
                    .fold(glam::DVec3::ZERO, |a, p| a + p.power.as_dvec3());
                let flux = flux.as_dvec3();
                assert!(
                    ((sum - flux).abs() / flux).max_element() < 1e-6,
                    "{kind:?}, n = {n}: {sum} vs {flux}"
                );
            }
        }
    }

    #[test]
    fn spot_flux_matches_numerical_integral_of_the_falloff() {
        for (inner, outer) in [(0.3f32, 0.7f32), (0.0, 1.2), (0.5, 0.5001), (0.0, 0.05)] {
            let (ci, co) = (inner.cos(), outer.cos());
            let n = 200_000;
            let numeric: f64 = (0..n)
                .map(|i| {
                    let c = co + (1.0 - co) * (i as f32 + 0.5) / n as f32;
                    spot_falloff(ci, co, c) as f64 * (1.0 - co) as f64 / n as f64
                })
                .sum();
            let exact = spot_falloff_integral(inner, outer) as f64;
            assert!(
                (numeric - exact).abs() <= 1e-3 * exact,
                "{inner},{outer}: {numeric} {exact}"
            );
        }
    }

    #[test]
    fn spot_photons_stay_inside_the_outer_cone_and_follow_the_falloff() {
        let kind = LightKind::Spot {
            inner_cone_angle: 0.2,
            outer_cone_angle: 0.6,
        };
        let l = light(kind, Vec3::ONE);
        let s = scene_with(vec![l.clone()]);
        let photons = emit_from_light(&s, 0, 20_000, 3);
        let cos_o = 0.6f32.cos();
        let cos_i = 0.2f32.cos();
        let inside_inner = photons
            .iter()
            .filter(|p| p.direction.dot(l.direction) >= cos_i)
            .count() as f32
            / photons.len() as f32;
        assert!(photons
            .iter()
            .all(|p| p.direction.dot(l.direction) >= cos_o - 1e-5));
        let expected = (1.0 - cos_i) / spot_falloff_integral(0.2, 0.6);
        assert!(
            (inside_inner - expected).abs() < 0.015,
            "{inside_inner} vs {expected}"
        );
    }

    #[test]
    fn emissive_surfaces_emit_photons_by_power_that_sum_to_their_flux() {
        // The icosphere (radius 3) glows with L_e = 0.5 from its outer side, and a point light.
        let mut s = scene_with(vec![light(LightKind::Point, Vec3::ONE)]);
        s.materials[0].emission = Vec3::new(0.5, 0.25, 1.0);
        let emitters = Emitters::of(&s);
        let flux = emitters.flux().as_dvec3();
        let photons = emit_photons(&s, 20_000, 5);
        let from_surface: Vec<_> = photons.iter().filter(|p| p.light == 1).collect();
        // Budget ∝ mean flux: emitter vs the point light's 4π.
        let share = mean(emitters.flux()) / (mean(emitters.flux()) + 4.0 * PI);
        let expected = (20_000.0 * share).round() as usize;
        assert_eq!(from_surface.len(), expected);
        let sum = from_surface
            .iter()
            .fold(glam::DVec3::ZERO, |a, p| a + p.power.as_dvec3());
        assert!(
            ((sum - flux).abs() / flux).max_element() < 1e-3,
            "{sum} vs {flux}"
        );
        // Outwards, cosine-distributed: E[cos θ] = 2/3 about each facet's outward normal.
        let mean_cos: f32 = from_surface
            .iter()
            .map(|p| p.direction.dot(p.origin.normalize()))
            .sum::<f32>()
            / from_surface.len() as f32;
        // (Facets within ~20° of the radial direction: a little under 2/3.)
        assert!(mean_cos > 0.6 && mean_cos < 0.68, "{mean_cos}");
    }

    #[test]
    fn budget_follows_power_and_skips_dark_lights() {
        let s = scene_with(vec![
            light(LightKind::Point, Vec3::ONE),
            light(LightKind::Point, Vec3::splat(3.0)),
            light(LightKind::Point, Vec3::ZERO),
        ]);
        assert_eq!(photon_budget(&s, 1000), vec![250, 750, 0]);
        // Skipping the brighter light gives its share to the other one.
        assert_eq!(
            photon_budget_among(&s, 1000, &[true, false, true]),
            vec![1000, 0, 0]
        );
        assert_eq!(photon_budget_among(&s, 1000, &[false]), vec![0, 0, 0]);
        let dark = scene_with(vec![light(LightKind::Point, Vec3::ZERO)]);
        assert!(emit_photons(&dark, 100, 1).is_empty());
    }
}
