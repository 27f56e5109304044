//! Hard cases, lights (issue #8): a light touching a surface, a light shut inside a closed
//! object, grazing light, degenerate spot cones, zero power, a 10⁶ contrast between lights and
//! hundreds of lights, each rendered end to end with ISPM on lavapipe with validation on
//! (`common::hard`).
//!
//! Photon accounting uses the closed grey box of albedo 1 (`reference::scenes::grey_box`):
//! every first bounce survives Russian roulette with weight 1, so the bounce map carries
//! exactly the flux the lights emitted.

mod common;

use common::hard::{self, load_glb, render_hard, stage, total_flux};
use glam::{Quat, Vec3};
use ispm::photon::emit::photon_budget;
use ispm::reference::scenes::grey_box;
use ispm::scene::authoring::{cuboid, GltfWriter};
use ispm::scene::{Light, LightKind, Scene};

fn spot(position: Vec3, direction: Vec3, intensity: f32, cone: (f32, f32)) -> Light {
    Light {
        name: "spot".into(),
        kind: LightKind::Spot {
            inner_cone_angle: cone.0,
            outer_cone_angle: cone.1,
        },
        position,
        direction: direction.normalize(),
        intensity: Vec3::splat(intensity),
    }
}

/// Relative error of the bounce map's power against the lights' flux.
fn flux_error(frame: &hard::HardFrame, scene: &Scene) -> f64 {
    let power = frame.bounce_map_power().element_sum() / 3.0;
    let flux = total_flux(scene);
    (power - flux).abs() / flux.max(1e-30)
}

/// The stage with a white block, lit by a point light `height` above the floor at x = −0.6.
fn touching(height: f32) -> Scene {
    let mut w = GltfWriter::default();
    let floor = stage(&mut w);
    let block = w.mesh("block", &cuboid(Vec3::splat(0.25)), floor);
    w.mesh_node("block", block, Vec3::new(0.3, 0.25, 0.0), Quat::IDENTITY);
    w.point("bulb", Vec3::new(-0.6, height, 0.0), [1.0; 3], 2.0);
    load_glb("touching", &w.glb())
}

#[test]
fn a_light_touching_a_surface() {
    // A point light on the floor (at distance 0 from it) and one a tenth of a millimetre above
    // it: finite everywhere (`render_hard`), and the first bounce within the energy bound.
    let case = "a_light_touching_a_surface";
    let (on_scene, above_scene) = (touching(0.0), touching(1e-4));
    let on = render_hard(case, &on_scene, hard::settings_for(20_000));
    let above = render_hard(case, &above_scene, hard::settings_for(20_000));
    // Energy: the first bounce never carries more than the white surfaces (ρ = 0.75) keep of
    // the flux. Touching, the floor gets nothing (the light grazes it) and the block what it
    // intercepts; 0.1 mm above, the floor also gets the whole lower hemisphere, ρ·Φ/2 (less the
    // directions within 10⁻⁴ rad of the horizon, which leave its 3 m square). The light views'
    // near plane, 10⁻⁶ of the scene's diagonal (4 µm here), lies below 0.1 mm
    // (`plan/lighting.rs`); at 10⁻⁴ (0.4 mm) the floor was hidden from the photons (2.73 W).
    let flux = total_flux(&on_scene);
    let (a, b) = (on.bounce_map_power().x, above.bounce_map_power().x);
    let expected = a + 0.75 * flux / 2.0;
    eprintln!(
        "{case}: first bounce carries {a:.5} W touching, {b:.5} W 0.1 mm above (expected \
         {expected:.5} W: the block's and ρ·Φ/2), of {flux:.4} W"
    );
    assert!(
        a > 0.0 && a <= 0.75 * flux && b <= 0.75 * flux,
        "{a} W, {b} W of {flux} W"
    );
    assert!(
        (b / expected - 1.0).abs() < 0.03,
        "{b} W 0.1 mm above, expected {expected} W"
    );
}

/// The touching light's direct light on the block it faces equals the light's 0.1 mm above the
/// floor (no photons: the direct light alone, deterministic). The floor itself differs, as the
/// physics says: at height h its irradiance I·h/r³ gathers the flux 2πI into a spot of radius
/// ≈ h at the light's foot, and at h = 0 it is 0 (the light grazes it).
#[test]
fn a_light_touching_a_surface_lights_what_it_faces_directly() {
    let case = "a_light_touching_a_surface_lights_what_it_faces_directly";
    let view = |h: f32| {
        let mut scene = touching(h);
        scene.camera =
            hard::camera_looking(Vec3::new(-1.0, 0.7, 1.0), Vec3::new(0.05, 0.25, 0.0), 0.6);
        render_hard(case, &scene, hard::settings_for(0))
    };
    let (on, above) = (view(0.0), view(1e-4));
    // The block: x ∈ [0.05, 0.55], y ∈ (0, 0.5].
    let on_block = |f: &hard::HardFrame| -> (f32, usize) {
        let mut sum = 0.0;
        let mut n = 0;
        for (i, p) in f.positions.iter().enumerate() {
            if let Some(p) = p {
                if p.x > 0.04 && p.y > 1e-3 {
                    sum += f.frame.hdr[i * 4..i * 4 + 3].iter().sum::<f32>();
                    n += 1;
                }
            }
        }
        (sum, n)
    };
    let ((a, n), (b, m)) = (on_block(&on), on_block(&above));
    eprintln!("{case}: the block's {n} pixels sum {a:.4} touching, {b:.4} 0.1 mm above");
    assert_eq!(n, m);
    assert!(n > 100 && b > 0.0, "the block is not in view");
    assert!((a / b - 1.0).abs() < 0.02, "{a} touching against {b} above");
}

#[test]
fn a_light_inside_a_closed_object() {
    // A point light at the centre of a closed, single-sided white box on the stage: no light
    // gets out (no direct light through its back faces, no photon outside it).
    let mut w = GltfWriter::default();
    let floor = stage(&mut w);
    let box_mesh = w.mesh("box", &cuboid(Vec3::splat(0.3)), floor);
    w.mesh_node("box", box_mesh, Vec3::new(0.0, 0.3, 0.0), Quat::IDENTITY);
    w.point("bulb", Vec3::new(0.0, 0.3, 0.0), [1.0; 3], 5.0);
    let scene = load_glb("lamp-in-a-box", &w.glb());
    let f = render_hard(
        "a_light_inside_a_closed_object",
        &scene,
        hard::settings_for(20_000),
    );
    let outside = f
        .photons
        .iter()
        .filter(|p| (p.position - Vec3::new(0.0, 0.3, 0.0)).abs().max_element() > 0.3 + 1e-3)
        .count();
    eprintln!(
        "a_light_inside_a_closed_object: peak {:.3e}, {} photons, {outside} outside",
        f.peak(),
        f.photons.len()
    );
    assert_eq!(outside, 0, "photons stored outside the closed box");
    if f.peak() > 0.0 {
        hard::save("a_light_inside_a_closed_object", &f.frame);
        panic!("light escapes the closed box: peak radiance {}", f.peak());
    }
}

#[test]
fn grazing_light() {
    // The sun 0.5° above the horizon on the bare floor: E·sin(0.5°)·ρ/π on every floor pixel.
    let (e, elevation) = (2.0f32, 0.5f32.to_radians());
    let mut w = GltfWriter::default();
    stage(&mut w);
    w.sun(
        "sun",
        Vec3::new(-elevation.cos(), -elevation.sin(), 0.0),
        [1.0; 3],
        e,
    );
    let scene = load_glb("grazing", &w.glb());
    let f = render_hard("grazing_light", &scene, hard::settings_for(20_000));
    let expected = e * elevation.sin() * 0.75 / std::f32::consts::PI;
    // The floor's middle (the camera sees the floor in the lower two thirds of the frame).
    let s = hard::SIZE;
    let floor = f.mean_where(|x, y| x > s / 4 && x < 3 * s / 4 && y > s / 2 && y < 7 * s / 8);
    let ratio = floor.element_sum() / 3.0 / expected;
    eprintln!(
        "grazing_light: floor {:.5} against {expected:.5} (ratio {ratio:.3})",
        floor.x
    );
    assert!(
        (0.8..1.25).contains(&ratio),
        "grazing floor radiance ratio {ratio}"
    );
}

#[test]
fn spot_with_zero_and_near_180_degree_cones() {
    let case = "spot_with_zero_and_near_180_degree_cones";
    let down = Vec3::new(0.1, -1.0, 0.05);
    let half_pi = std::f32::consts::FRAC_PI_2;
    for (name, cone) in [
        ("zero", (0.0, 0.0)),
        ("needle", (0.0, 1e-4)),
        ("hemisphere", (half_pi - 0.01, half_pi)),
    ] {
        let mut scene = grey_box(1.0, 1.0);
        scene.lights = vec![spot(Vec3::new(0.0, 0.3, 0.0), down, 3.0, cone)];
        let f = render_hard(case, &scene, hard::first_bounce_for(20_000));
        let flux = total_flux(&scene);
        eprintln!(
            "{case}: {name} cone {cone:?}: flux {flux:.4e}, bounce map {:.4e}, peak {:.3e}",
            f.bounce_map_power().x,
            f.peak()
        );
        if flux == 0.0 {
            assert_eq!(f.frame.stats.emitted_photons, 0, "{name}");
            assert_eq!(f.peak(), 0.0, "{name}: a zero cone lights something");
        } else if cone.1 < 1e-3 {
            // A needle: cos(10⁻⁴) rounds to 1 in f32, so the falloff the bounce map evaluates
            // is coarse and the relative error large, on a flux of 10⁻¹⁶ W: bounded in watts.
            let error = (f.bounce_map_power().element_sum() / 3.0 - flux).abs();
            assert!(
                error < 1e-12,
                "{name}: bounce map off the flux by {error} W"
            );
        } else {
            assert!(flux_error(&f, &scene) < 1e-3, "{name}: bounce map ≠ flux");
        }
    }
}

#[test]
fn zero_power() {
    let case = "zero_power";
    let mut scene = grey_box(0.7, 0.0);
    let alone = render_hard(case, &scene, hard::settings_for(20_000));
    assert_eq!(alone.frame.stats.emitted_photons, 0);
    assert_eq!(alone.peak(), 0.0, "a dark light lights the box");
    // Beside a real light it takes none of the budget.
    scene
        .lights
        .push(spot(Vec3::ZERO, Vec3::NEG_Y, 1.0, (0.3, 0.5)));
    assert_eq!(photon_budget(&scene, 20_000), vec![0, 20_000]);
    let both = render_hard(case, &scene, hard::settings_for(20_000));
    assert!(both.view_texels.iter().all(|&(_, light)| light == 1));
    assert!(both.mean().element_sum() > 0.0);
}

#[test]
fn one_light_a_million_times_brighter_than_another() {
    let case = "one_light_a_million_times_brighter_than_another";
    let mut scene = grey_box(1.0, 1e6);
    scene
        .lights
        .push(spot(Vec3::new(0.3, 0.5, 0.2), Vec3::NEG_Y, 1.0, (0.2, 0.4)));
    let f = render_hard(case, &scene, hard::first_bounce_for(20_000));
    let error = flux_error(&f, &scene);
    eprintln!(
        "{case}: bounce map against flux {error:.2e}, peak {:.3e}",
        f.peak()
    );
    assert!(
        error < 1e-3,
        "the bounce map carries {error} too much or too little"
    );
    assert!(f.peak() > 1e5, "the bright light's radiance is missing");
}

/// `n` spot lights inside the grey box, positions, directions, powers and cones spread by a
/// fixed low-discrepancy sequence.
fn many_spots(n: usize) -> Scene {
    let mut scene = grey_box(1.0, 1.0);
    let frac = |x: f32| x - x.floor();
    scene.lights = (0..n)
        .map(|i| {
            let t = i as f32;
            let u = [
                frac(t * 0.618_034),
                frac(t * 0.754_878),
                frac(t * 0.569_840),
            ];
            let position = Vec3::new(u[0] - 0.5, u[1] - 0.5, u[2] - 0.5) * 1.6;
            let direction = Vec3::new(u[2] - 0.5, -1.0, u[0] - 0.5);
            let outer = 0.3 + 0.7 * u[1];
            spot(position, direction, 0.1 + 10.0 * u[2], (0.5 * outer, outer))
        })
        .collect();
    scene
}

#[test]
fn hundreds_of_lights() {
    let case = "hundreds_of_lights";
    let (n, photons) = (256, 20_000);
    let scene = many_spots(n);
    let budget = photon_budget(&scene, photons);
    assert_eq!(
        budget.iter().sum::<usize>(),
        photons,
        "the budget misses the total"
    );
    let settings = ispm::config::settings::RenderSettings {
        shadow_resolution: 64,
        ..hard::first_bounce_for(photons)
    };
    // Each light emits its budget: 78 photons each, to within the binomial spread of the
    // texels' keep test (src/plan/bounce_plan.rs, "Budget"), so all of them to within 1 %.
    let kept = render_hard(case, &scene, settings.clone());
    let sent = kept.frame.stats.emitted_photons;
    eprintln!("{case}: {sent} photons sent of {photons}");
    assert!(
        (sent as f64 / photons as f64 - 1.0).abs() <= 0.01,
        "{sent} photons sent for a budget of {photons}"
    );
    // With whole grids every texel inside a cone hits a wall of albedo 1 and keeps its power:
    // the records with power are the photons the lights emitted, and they carry exactly the
    // lights' flux. Each light's views are square, so its count rounds up by at most 2√n_L + 1
    // (and its cone's share is measured on a probe grid).
    let settings = ispm::config::settings::RenderSettings {
        whole_light_grids: true,
        ..settings
    };
    let f = render_hard(case, &scene, settings);
    let carried = f
        .bounce_map
        .iter()
        .filter(|p| p.power.max_element() > 0.0)
        .count();
    let rounding: f64 = budget.iter().map(|&b| 2.0 * (b as f64).sqrt() + 1.0).sum();
    let error = flux_error(&f, &scene);
    eprintln!(
        "{case}: {n} lights, {carried} photons carry power (budget {photons}, rounding {rounding:.0}), {} texels, flux error {error:.2e}",
        f.frame.stats.emitted_photons
    );
    assert!(
        carried as f64 >= 0.97 * photons as f64 && carried as f64 <= photons as f64 + rounding,
        "{carried} photons for a budget of {photons}"
    );
    assert!(
        error < 1e-3,
        "the photons carry {error} more or less than the lights' flux"
    );
    // Every light with a share of the budget has views (a light whose share rounds to 0
    // photons has none; its flux is then missing from the bounce map, within the 10⁻³ above).
    let lights_with_views: std::collections::BTreeSet<usize> =
        f.view_texels.iter().map(|&(_, l)| l).collect();
    let budgeted: std::collections::BTreeSet<usize> = (0..n).filter(|&l| budget[l] > 0).collect();
    assert_eq!(lights_with_views, budgeted, "lights without photons");
}
