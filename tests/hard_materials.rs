//! Hard cases, materials (issue #8): albedo exactly 1 in a closed sphere, glossy exponents 0 and
//! 10⁶, glass of η = 1 and η = 3, total internal reflection and two facing mirrors, each
//! rendered end to end with ISPM on lavapipe with validation on (`common::hard`).

mod common;

use common::hard::{self, add_mesh, load_glb, render_hard, stage, total_flux as flux};
use glam::{Mat4, Quat, Vec3};
use ispm::config::settings::RenderSettings;
use ispm::reference::scenes::{furnace_sphere, grey_box};
use ispm::scene::authoring::{icosphere, quad, GltfWriter, MaterialSpec};
use ispm::scene::{Material, Scene};
use std::f32::consts::PI;

#[test]
fn albedo_exactly_one_in_a_closed_sphere() {
    // DESIGN §6's furnace with ρ = 1 and I = π: every path survives every bounce, so each of
    // the B bounces the trace allows stores the whole flux once, and the radiance is 1 (direct)
    // plus 1 per stored bounce (the geometric series Σ ρᵏ at ρ = 1, cut at B): finite, and
    // exactly 1 + B on the smooth sphere (the faceted one is ≈ 1 % brighter: physics_furnace.rs).
    let scene = furnace_sphere(3, 1.0, PI);
    // The kernel radius of physics_furnace.rs (its bias on the facets ≈ 1.5 %).
    let settings = ispm::config::settings::RenderSettings {
        bounces: 4,
        radius: Some(0.05),
        ..hard::settings_for(40_000)
    };
    let f = render_hard("albedo_exactly_one_in_a_closed_sphere", &scene, settings);
    let stats = &f.frame.stats;
    let b = f.max_bounces as usize;
    let per_path = stats.stored_photons as f64 / stats.bounce_map_photons.max(1) as f64;
    let stored = f.stored_power().element_sum() / 3.0 / flux(&scene);
    let radiance = f64::from(f.mean().element_sum() / 3.0);
    eprintln!(
        "albedo 1: B = {b}, {per_path:.4} stored photons per path, stored power {stored:.5} × flux, radiance {radiance:.4} (1 + B = {})",
        1 + b
    );
    // Every path stores B photons, but for the few whose bounce-map hit point, rebuilt from
    // the light G-buffer's depth, lands a hair outside the sphere (they leave it).
    let paths = (stats.bounce_map_photons * b) as f64;
    assert!(stats.stored_photons as f64 >= 0.99 * paths && stats.stored_photons as f64 <= paths);
    assert!(
        (stored - b as f64).abs() < 1e-2 * b as f64,
        "stored power {stored} × flux, not {b}"
    );
    assert!(
        (radiance / (1 + b) as f64 - 1.0).abs() < 0.05,
        "radiance {radiance}, not 1 + B = {}",
        1 + b
    );
}

/// The closed grey box with the walls of `material` and a point light at the centre.
fn box_of(material: Material) -> Scene {
    let mut scene = grey_box(1.0, 1.0);
    scene.materials = vec![material];
    for m in &mut scene.meshes {
        m.material = 0;
    }
    scene
}

#[test]
fn glossy_exponent_zero_and_very_large() {
    // A closed box of glossy walls (ρS = 1): the bounce map keeps the flux, whatever the
    // exponent. The energy-compensated lobe (issue #19) keeps what its shape loses (at σ = 0 the
    // half vectors are uniform over the hemisphere and most reflected directions go below it:
    // the GPU's first bounce kept only 0.1–0.45 of the flux before); this checks the GLSL twin
    // of the compensation (`bsdf_glossy_albedo`) on the GPU.
    for (exponent, least) in [(0.0, 0.98), (1e6, 0.98)] {
        let scene = box_of(Material {
            lambertian: Vec3::ZERO,
            glossy: Vec3::ONE,
            exponent,
            ..Material::default()
        });
        let f = render_hard(
            "glossy_exponent_zero_and_very_large",
            &scene,
            hard::first_bounce_for(20_000),
        );
        let kept = f.bounce_map_power().element_sum() / 3.0 / flux(&scene);
        eprintln!("glossy exponent {exponent}: the first bounce keeps {kept:.4} of the flux");
        assert!(
            (least..=1.02).contains(&kept),
            "exponent {exponent}: {kept}"
        );
    }
}

/// The lit stage with a sphere of radius 0.35 of `material` at (0, 0.35, 0), or without.
fn stage_with_ball(material: Option<MaterialSpec>) -> Scene {
    let mut w = GltfWriter::default();
    stage(&mut w);
    hard::overhead_spot(&mut w);
    if let Some(m) = material {
        let m = w.material(&m);
        let ball = w.mesh("ball", &icosphere(0.35, 3), m);
        w.mesh_node("ball", ball, Vec3::new(0.0, 0.35, 0.0), Quat::IDENTITY);
    }
    load_glb("ball", &w.glb())
}

fn glass(name: &'static str, eta: f32) -> MaterialSpec {
    MaterialSpec {
        transmission: [1.0; 3],
        transmission_factor: 1.0,
        glossy: [0.0; 3],
        ior: eta,
        ior_ext: Some(eta),
        ..MaterialSpec::glass(name)
    }
}

/// The stage with a sphere of radius 0.35 at (0, 0.35, 0) of `material`, or without, lit by
/// a spot from the side so that the ball's shadow falls on floor the camera sees.
fn side_lit_ball(material: Option<MaterialSpec>) -> Scene {
    let mut w = GltfWriter::default();
    stage(&mut w);
    let at = Vec3::new(0.9, 1.2, -0.9);
    w.spot(
        "spot",
        at,
        Vec3::new(0.0, 0.35, 0.0),
        [1.0; 3],
        4.0,
        (0.6, 0.8),
    );
    if let Some(m) = material {
        let m = w.material(&m);
        let ball = w.mesh("ball", &icosphere(0.35, 3), m);
        w.mesh_node("ball", ball, Vec3::new(0.0, 0.35, 0.0), Quat::IDENTITY);
    }
    load_glb("ball", &w.glb())
}

#[test]
fn glass_of_eta_one_is_invisible() {
    // Glass of η = 1 (no Fresnel reflection, transmission 1): its shadow in the direct light is
    // filled by the photons that pass through it unbent, so the floor around and behind the
    // ball is the same as without it. Where the eye looks *through* the ball the translucent
    // pass shows the environment cube maps (direct light, and the photons' indirect light
    // gathered from the ball's centre: docs/overview.md), an approximation held to 7 % of the
    // bare floor (0.857 of it when the cube held direct light only; now 0.991).
    let case = "glass_of_eta_one_is_invisible";
    let settings = hard::settings_for(20_000);
    let without = render_hard(case, &side_lit_ball(None), settings.clone());
    let scene = side_lit_ball(Some(glass("eta-1", 1.0)));
    let with = render_hard(case, &scene, settings);
    let camera = scene.camera;
    let through_ball = |x: u32, y: u32| {
        let centre = Vec3::new(0.0, 0.35, 0.0);
        let p = camera
            .project_to_pixel(centre, hard::SIZE, hard::SIZE)
            .expect("in view");
        let d = camera.position().distance(centre);
        let r = 0.35 / (d * (camera.yfov * 0.5).tan()) * hard::SIZE as f32 * 0.5;
        (glam::Vec2::new(x as f32 + 0.5, y as f32 + 0.5) - p).length() < r + 1.5
    };
    let outside = |x: u32, y: u32| !through_ball(x, y);
    let (a, b) = (with.mean_where(outside), without.mean_where(outside));
    let mut diff = 0.0f32;
    let mut n = 0;
    for y in 0..hard::SIZE {
        for x in 0..hard::SIZE {
            if outside(x, y) {
                diff += (with.pixel(x, y) - without.pixel(x, y)).abs().element_sum();
                n += 1;
            }
        }
    }
    let relative = diff / n as f32 / b.element_sum();
    let inside = with.mean_where(through_ball).element_sum()
        / without.mean_where(through_ball).element_sum();
    eprintln!(
        "{case}: outside the ball mean {:.4} vs {:.4}, mean |difference| {relative:.4} of it; seen through the ball {inside:.3} of the bare floor",
        a.element_sum(),
        b.element_sum()
    );
    if relative > 0.05 {
        common::golden::write_failure_images(
            case,
            hard::SIZE,
            hard::SIZE,
            &with.frame.hdr,
            Some(&without.frame.hdr),
        );
        panic!("η = 1 glass changes the image around it by {relative}");
    }
    assert!(
        (0.93..1.07).contains(&inside),
        "seen through η = 1 glass the floor is {inside:.3} of the bare floor"
    );
}

#[test]
fn glass_of_eta_three_and_total_internal_reflection() {
    // η = 3 (critical angle 19.5°: most light inside the ball is reflected totally) in a closed
    // box of albedo 1 with the light outside the ball. Nothing absorbs at the first bounce
    // (walls of albedo 1, glass of transmission 1 and Fresnel reflection), so the bounce map
    // carries the flux; the photons that enter the ball bounce inside until they leave or the
    // bounce limit ends them, never adding power.
    for eta in [1.5f32, 3.0] {
        let mut scene = grey_box(1.0, 1.0);
        scene.lights[0].position = Vec3::new(0.5, 0.5, 0.0);
        // A smooth dielectric exactly (bsdf.rs, "Fresnel"): ρS = F0, ρt = 1 − F0.
        let f0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
        scene.materials.push(Material {
            lambertian: Vec3::ZERO,
            glossy: Vec3::splat(f0),
            exponent: f32::INFINITY,
            transmission: Vec3::splat(1.0 - f0),
            ior: eta,
            fresnel: true,
            ..Material::default()
        });
        let mut ball = ispm::photon::shapes::icosphere(3);
        ball.material = scene.materials.len() - 1;
        add_mesh(
            &mut scene,
            ball,
            Mat4::from_scale_rotation_translation(
                Vec3::splat(0.4),
                Quat::IDENTITY,
                Vec3::new(-0.3, -0.4, -0.2),
            ),
        );
        let f = render_hard(
            "glass_of_eta_three_and_total_internal_reflection",
            &scene,
            // Sixteen bounces: paths inside the ball and between the walls of albedo 1 never end
            // by Russian roulette, and sixteen are enough to store photons after many passes
            // through the glass (the default cap of 256 traces 16 times longer for the same check).
            RenderSettings {
                bounces: 16,
                ..hard::settings_for(20_000)
            },
        );
        let kept = f.bounce_map_power().element_sum() / 3.0 / flux(&scene);
        let b = f.max_bounces as f64;
        let stored = f.stored_power().element_sum() / 3.0 / flux(&scene);
        eprintln!("η = {eta}: bounce map {kept:.5} × flux, stored {stored:.4} × flux (B = {b})");
        assert!(
            (kept - 1.0).abs() < 1e-3,
            "η = {eta}: the first bounce carries {kept} × flux"
        );
        assert!(
            stored <= b + 1e-3,
            "η = {eta}: stored power {stored} × flux > B = {b}"
        );
        let off_walls: Vec<_> = f
            .photons
            .iter()
            .filter(|p| p.position.abs().max_element() < 0.999)
            .map(|p| p.position)
            .take(5)
            .collect();
        assert!(
            off_walls.is_empty(),
            "η = {eta}: photons stored off the walls: {off_walls:?}"
        );
    }
}

#[test]
fn a_mirror_facing_a_mirror() {
    // Two perfect mirrors (ρ = 1) 1 m apart facing each other on the floor, a spot between them
    // aiming across: Russian roulette never ends a path between them, the bounce limit does.
    let mut w = GltfWriter::default();
    let _ = stage(&mut w);
    let mirror = w.material(&MaterialSpec::mirror("mirror", [1.0; 3]));
    for (name, x, n) in [("left", -0.5, Vec3::X), ("right", 0.5, Vec3::NEG_X)] {
        let m = w.mesh(name, &quad(Vec3::new(x, 0.5, 0.0), n, 0.5, 0.6), mirror);
        w.mesh_node(name, m, Vec3::ZERO, Quat::IDENTITY);
    }
    // Aimed almost square at the right mirror: each crossing drops 2 cm, so a path crosses
    // between them dozens of times before it leaves.
    let from = Vec3::new(0.0, 0.9, 0.0);
    w.spot(
        "spot",
        from,
        from + Vec3::new(1.0, -0.02, -0.01),
        [1.0; 3],
        5.0,
        (0.02, 0.04),
    );
    let scene = load_glb("mirrors", &w.glb());
    let start = std::time::Instant::now();
    // Eight bounces, so that every path is still between the mirrors when the limit ends it
    // (with the default safety cap of 256 they drift off the mirrors' lower edge first).
    let f = render_hard(
        "a_mirror_facing_a_mirror",
        &scene,
        RenderSettings {
            bounces: 8,
            ..hard::settings_for(20_000)
        },
    );
    let stats = &f.frame.stats;
    let b = f.max_bounces as usize;
    eprintln!(
        "a_mirror_facing_a_mirror: attrition {:?}, {} stored, {:.1} s",
        stats.attrition,
        stats.stored_photons,
        start.elapsed().as_secs_f64()
    );
    assert_eq!(stats.attrition.len(), b + 1, "attrition per bounce up to B");
    // attrition[0] is the CPU tracer's emission count, which the GPU bounce map replaces.
    assert!(
        stats.attrition[1..].windows(2).all(|a| a[1] <= a[0]),
        "attrition grows"
    );
    assert!(stats.stored_photons <= stats.bounce_map_photons * b);
    // A perfect mirror keeps every photon: Russian roulette ends none, the bounce limit all.
    assert_eq!(
        stats.attrition[b], stats.attrition[1],
        "Russian roulette ended a path"
    );
}

#[test]
fn glass_of_eta_three_on_the_stage() {
    // The same ball as η = 1, now with η = 3, under the spot: caustic photons on the floor,
    // all finite (`render_hard`), none stored on the glass.
    let f = render_hard(
        "glass_of_eta_three_on_the_stage",
        &stage_with_ball(Some(glass("eta-3", 3.0))),
        hard::settings_for(20_000),
    );
    assert!(f.frame.stats.stored_photons > 0);
    assert!(
        f.photons.iter().all(|p| p.position.y.abs() < 1e-3),
        "photons off the floor"
    );
}
