//! Photon power accounting, determinism and robustness of the CPU photon tracer.

use glam::{DVec3, Mat4, Vec2, Vec3};
use ispm::photon::bvh::SceneBvh;
use ispm::photon::emit::{emit_from_light, emit_photons, light_flux};
use ispm::photon::shapes::icosphere;
use ispm::photon::trace::{
    first_bounce, trace_from_lights, trace_photons, PhotonState, StoreOn, TraceSettings,
    MAX_DELTA_CHAIN,
};
use ispm::photon::types::unpack_direction;
use ispm::reference::scenes::{furnace_sphere, grey_box};
use ispm::scene::{Instance, Light, LightKind, Mesh};

fn sum_power(p: impl Iterator<Item = Vec3>) -> DVec3 {
    p.fold(DVec3::ZERO, |a, v| a + v.as_dvec3())
}

#[test]
fn photon_power_sums_to_flux_for_point_spot_and_directional_lights() {
    let mut scene = grey_box(0.5, 1.0);
    let intensity = Vec3::new(0.5, 1.0, 2.0);
    scene.lights = [
        LightKind::Point,
        LightKind::Spot {
            inner_cone_angle: 0.25,
            outer_cone_angle: 0.9,
        },
        LightKind::Directional,
    ]
    .into_iter()
    .map(|kind| Light {
        name: format!("{kind:?}"),
        kind,
        position: Vec3::new(0.1, 0.5, -0.2),
        direction: Vec3::new(0.2, -1.0, 0.1).normalize(),
        intensity,
    })
    .collect();
    let bounds = scene.bounds();
    for (i, light) in scene.lights.iter().enumerate() {
        let flux = light_flux(light, &bounds).as_dvec3();
        let sum = sum_power(emit_from_light(&scene, i, 4099, 1).iter().map(|p| p.power));
        let err = ((sum - flux).abs() / flux).max_element();
        assert!(err < 1e-6, "{:?}: {sum} vs {flux}", light.kind);
    }
    // All lights together, budgeted by power: the total is still the total flux.
    let total: DVec3 = scene
        .lights
        .iter()
        .map(|l| light_flux(l, &bounds).as_dvec3())
        .sum();
    let sum = sum_power(emit_photons(&scene, 10_000, 2).iter().map(|p| p.power));
    assert!(((sum - total).abs() / total).max_element() < 1e-6);
}

/// In a closed grey box of albedo ρ with a point light, the power stored after k bounces is
/// Φ·ρ^k: each bounce survives Russian roulette with probability ρ and keeps its power (weight
/// ρ/ρ = 1). The count after k bounces is binomial(N, ρ^k); we allow 5 standard deviations.
#[test]
fn stored_power_per_bounce_follows_the_geometric_series_in_a_closed_box() {
    for rho in [0.3f32, 0.7] {
        let scene = grey_box(rho, 1.0);
        let bvh = SceneBvh::new(&scene);
        let n = 20_000usize;
        let emitted = emit_photons(&scene, n, 11);
        let flux = light_flux(&scene.lights[0], &scene.bounds()).x as f64;
        let settings = TraceSettings {
            max_bounces: 8,
            seed: 5,
            ..Default::default()
        };
        let map = trace_from_lights(&scene, &bvh, &emitted, &settings);
        assert_eq!(
            map.stored_power[0],
            Vec3::ZERO,
            "direct photons are never stored"
        );
        assert_eq!(map.attrition[0], n as u64);
        // Closed box, every surface diffuse: every surviving photon is stored once per hit.
        assert_eq!(
            map.photons.len() as u64,
            map.attrition[1..].iter().sum::<u64>()
        );
        for k in 1..=8 {
            let p = (rho as f64).powi(k as i32);
            let expected = flux * p;
            let sigma = flux * (p * (1.0 - p) / n as f64).sqrt();
            let got = map.stored_power[k].x as f64;
            assert!(
                (got - expected).abs() < 5.0 * sigma + 1e-9,
                "ρ = {rho}, k = {k}: {got} vs {expected} ± {sigma}"
            );
            let alive = map.attrition[k] as f64 / n as f64;
            assert!((alive - p).abs() < 5.0 * (p * (1.0 - p) / n as f64).sqrt());
        }
    }
}

/// On 16 threads the trace's chunks are smaller (`photon::trace`, about eight per thread):
/// the photons and the attrition are still the same bit for bit.
#[test]
fn photon_map_is_bit_identical_with_one_two_and_sixteen_threads() {
    let scene = furnace_sphere(2, 0.6, 1.0);
    let bvh = SceneBvh::new(&scene);
    let emitted = emit_photons(&scene, 5_000, 3);
    let settings = TraceSettings {
        max_bounces: 12,
        seed: 9,
        ..Default::default()
    };
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| trace_from_lights(&scene, &bvh, &emitted, &settings))
    };
    let one = run(1);
    assert!(one.photons.len() > 1000);
    for threads in [2, 16] {
        let many = run(threads);
        assert_eq!(
            bytemuck::cast_slice::<_, u8>(&one.photons),
            bytemuck::cast_slice::<_, u8>(&many.photons),
            "{threads} threads"
        );
        assert_eq!(one.attrition, many.attrition, "{threads} threads");
    }
}

/// The GPU path (bounce-map records + positions) and the CPU path share the continuation:
/// the same states give the same photons, and a round trip through `BounceMapPhoton` keeps
/// power, direction, ρp and η.
#[test]
fn bounce_map_photons_continue_like_cpu_first_bounces() {
    let scene = grey_box(0.5, 1.0);
    let bvh = SceneBvh::new(&scene);
    let emitted = emit_photons(&scene, 2_000, 4);
    let states: Vec<PhotonState> = emitted
        .iter()
        .filter_map(|p| first_bounce(&scene, &bvh, p))
        .collect();
    assert!(states.iter().all(|s| s.bounces == 1));
    for s in &states {
        let record = s.to_bounce_map(1.0);
        let back = PhotonState::from_bounce_map(&record, s.origin, 0.0, s.path_key).unwrap();
        assert_eq!(back.power, s.power);
        assert!((back.direction - s.direction).length() < 1e-6);
        // ρp rides on ‖v‖ = ρp + 1: f32 keeps it to one ulp of 1 (types.rs's packing docs).
        assert!((back.rho_p - s.rho_p).abs() <= 2.5e-7 + 1e-6 * s.rho_p);
        assert_eq!(back.eta, s.eta);
    }
    let settings = TraceSettings::default();
    let a = trace_photons(&scene, &bvh, &states, &settings);
    let b = trace_from_lights(&scene, &bvh, &emitted, &settings);
    assert_eq!(a.photons, b.photons);
    // Stored photons carry ρp = product of the lobe factors: ρ/1000 per diffuse bounce.
    for p in &a.photons {
        let (_, rho) = unpack_direction(p.direction);
        assert!(rho <= 0.5e-3 + 2.5e-7, "ρp = {rho}");
    }
}

/// A refracting sphere inside the box: photons that enter carry η = ior, those that leave
/// again η = 1, and no photon is stored on the glass itself.
#[test]
fn photons_track_eta_through_glass_and_are_not_stored_on_it() {
    let mut scene = grey_box(0.5, 1.0);
    scene.materials.push(ispm::scene::Material {
        name: "glass".into(),
        lambertian: Vec3::ZERO,
        glossy: Vec3::splat(0.04),
        exponent: f32::INFINITY,
        transmission: Vec3::splat(0.96),
        ior: 1.5,
        fresnel: true,
        ..Default::default()
    });
    let mut ball = icosphere(2);
    ball.material = scene.materials.len() - 1;
    scene.meshes.push(ball);
    scene.instances.push(Instance {
        name: "ball".into(),
        mesh: scene.meshes.len() - 1,
        transform: Mat4::from_scale(Vec3::splat(0.4))
            * Mat4::from_translation(Vec3::new(0.0, -1.0, 0.0)),
    });
    scene.lights[0].position = Vec3::new(0.0, 0.8, 0.0);
    let bvh = SceneBvh::new(&scene);
    let emitted = emit_photons(&scene, 5_000, 8);
    let states: Vec<PhotonState> = emitted
        .iter()
        .filter_map(|p| first_bounce(&scene, &bvh, p))
        .collect();
    let inside = states.iter().filter(|s| (s.eta - 1.5).abs() < 1e-6).count();
    assert!(inside > 50, "{inside} photons entered the glass");
    assert!(states
        .iter()
        .all(|s| (s.eta - 1.0).abs() < 1e-6 || (s.eta - 1.5).abs() < 1e-6));
    let map = trace_from_lights(&scene, &bvh, &emitted, &TraceSettings::default());
    for p in &map.photons {
        // The ball has radius 0.4 about (0, −0.4, 0); its facets lie inside that sphere.
        let r = (p.position - Vec3::new(0.0, -0.4, 0.0)).length();
        assert!(r > 0.401, "photon stored on the glass at r = {r}");
    }
    // Caustic photons (through the glass only) have ρp near 1: much larger than diffuse ones.
    assert!(map
        .photons
        .iter()
        .any(|p| unpack_direction(p.direction).1 > 0.1));
}

#[test]
fn zero_power_lights_and_degenerate_triangles_give_finite_photons() {
    let mut scene = furnace_sphere(2, 0.5, 1.0);
    scene.lights.push(Light {
        name: "dark".into(),
        kind: LightKind::Point,
        position: Vec3::new(0.1, 0.0, 0.0),
        direction: Vec3::NEG_Y,
        intensity: Vec3::ZERO,
    });
    // Zero-area and collinear triangles in the middle of the sphere.
    let p = vec![
        Vec3::new(0.2, 0.2, 0.2),
        Vec3::new(0.2, 0.2, 0.2),
        Vec3::new(0.4, 0.4, 0.4),
        Vec3::new(0.6, 0.6, 0.6),
    ];
    scene.meshes.push(Mesh {
        name: "degenerate".into(),
        normals: vec![Vec3::Y; p.len()],
        uvs: vec![Vec2::ZERO; p.len()],
        positions: p,
        triangles: vec![[0, 1, 2], [1, 2, 3], [0, 0, 0]],
        material: 0,
    });
    scene.instances.push(Instance {
        name: "degenerate".into(),
        mesh: 1,
        transform: Mat4::IDENTITY,
    });
    let bvh = SceneBvh::new(&scene);
    let emitted = emit_photons(&scene, 3_000, 1);
    assert!(
        emitted.iter().all(|p| p.light == 0),
        "the dark light emits nothing"
    );
    let map = trace_from_lights(&scene, &bvh, &emitted, &TraceSettings::default());
    assert!(!map.photons.is_empty());
    for p in &map.photons {
        for v in [p.power, p.direction, p.position, p.normal] {
            assert!(v.is_finite(), "{p:?}");
        }
    }
    // Only a dark light: nothing at all, and no NaN.
    scene.lights.remove(0);
    let emitted = emit_photons(&scene, 3_000, 1);
    assert!(emitted.is_empty());
    assert!(
        trace_from_lights(&scene, &bvh, &emitted, &TraceSettings::default())
            .photons
            .is_empty()
    );
}

/// `cornell-box`'s glass sphere is tessellated, and its interpolated shading normals let some
/// photons in at angles that total internal reflection (albedo 1, so roulette never ends
/// them) keeps: before `MAX_DELTA_CHAIN` they circled inside to the 256-bounce cap, 0.7 % of
/// the photons and 38 % of the rays traced. Now nothing is alive long after the chain's limit.
#[test]
fn total_internal_reflection_does_not_keep_photons_to_the_bounce_cap() {
    let scene = ispm::scene::bundled::resolve(Some("cornell-box")).expect("cornell-box");
    let bvh = SceneBvh::new(&scene);
    let emitted = emit_photons(&scene, 20_000, 4);
    let map = trace_from_lights(&scene, &bvh, &emitted, &TraceSettings::default());
    let cap = MAX_DELTA_CHAIN as usize;
    // Caught photons exist (the case is real), and the chain's limit ends them: past four times
    // the limit, only a photon that met a diffuse surface in between every 32 bounces could
    // be alive, and the room's albedo (≤ 0.8) makes that vanishingly rare.
    assert!(
        map.attrition[cap] > 0,
        "no photon reached {cap} bounces: the case is not exercised ({:?})",
        &map.attrition[..cap + 1]
    );
    assert_eq!(
        map.attrition[4 * cap],
        0,
        "photons alive after {} bounces: {:?}",
        4 * cap,
        &map.attrition[..4 * cap + 1]
    );
}

/// ISPM's photon map (`StoreOn::EyeGBuffer`) is the references' (`StoreOn::FiniteLobes`)
/// less the photons on surfaces the eye G-buffer does not hold (materials with a delta lobe):
/// the same paths, in the same order, so the same photons everywhere else.
#[test]
fn the_eye_gbuffer_photon_map_drops_exactly_the_photons_on_glass_and_mirrors() {
    let scene = ispm::scene::bundled::resolve(Some("cornell-box")).expect("cornell-box");
    let bvh = SceneBvh::new(&scene);
    let emitted = emit_photons(&scene, 10_000, 6);
    let trace = |store_on| {
        let settings = TraceSettings {
            store_on,
            ..Default::default()
        };
        trace_from_lights(&scene, &bvh, &emitted, &settings)
    };
    let all = trace(StoreOn::FiniteLobes);
    let eye = trace(StoreOn::EyeGBuffer);
    assert_eq!(all.attrition, eye.attrition, "the same paths");
    // The bounds of every delta-lobed instance (cornell-box: the glass sphere).
    let mut delta_bounds = Vec::new();
    for inst in &scene.instances {
        let mesh = &scene.meshes[inst.mesh];
        if scene.materials[mesh.material].has_delta_lobe() {
            let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
            for &p in &mesh.positions {
                let w = inst.transform.transform_point3(p);
                lo = lo.min(w);
                hi = hi.max(w);
            }
            delta_bounds.push((lo - 1e-3, hi + 1e-3));
        }
    }
    assert!(!delta_bounds.is_empty(), "cornell-box has glass");
    let on_delta = |p: Vec3| {
        delta_bounds
            .iter()
            .any(|&(lo, hi)| p.cmpge(lo).all() && p.cmple(hi).all())
    };
    // `eye` is `all` with the photons on delta surfaces taken out, order kept.
    let mut kept = eye.photons.iter().peekable();
    let mut dropped = 0;
    for p in &all.photons {
        if kept
            .peek()
            .is_some_and(|&&k| bytemuck::bytes_of(&k) == bytemuck::bytes_of(p))
        {
            kept.next();
        } else {
            assert!(
                on_delta(p.position),
                "a photon at {:?}, off the glass, was dropped",
                p.position
            );
            dropped += 1;
        }
    }
    assert!(
        kept.next().is_none(),
        "the eye map holds a photon the full map does not"
    );
    assert!(
        dropped > 0,
        "no photon was stored on the glass: the case is not exercised"
    );
}
