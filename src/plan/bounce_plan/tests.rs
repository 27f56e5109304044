//! Unit tests of the bounce plan (src/plan/bounce_plan.rs).

use super::texels::{texel_ndc, unproject, FAR, NEAR};
use super::*;
use crate::layout::shared_constants::{BOUNCE_VIEW_PARENT, BOUNCE_VIEW_WHOLE};
use crate::photon::emit::photon_budget;
use crate::photon::rng::hash2;
use crate::photon::types::BounceMapPhoton;
use crate::scene::{Light, LightKind, Scene};
use glam::Vec3;

fn scene_with(lights: Vec<Light>) -> Scene {
    let mut s = crate::photon::shapes::scene_of(vec![(
        crate::photon::shapes::icosphere(2),
        glam::Mat4::IDENTITY,
    )]);
    s.lights = lights;
    s
}

/// A point light (6 views) and a spot light (1 view) ten times as intense, at the origin.
fn point_and_spot() -> Scene {
    let point = Light {
        name: "p".into(),
        kind: LightKind::Point,
        position: Vec3::ZERO,
        direction: Vec3::NEG_Y,
        intensity: Vec3::splat(3.0),
    };
    let spot = Light {
        name: "s".into(),
        kind: LightKind::Spot {
            inner_cone_angle: 0.3,
            outer_cone_angle: 0.5,
        },
        intensity: Vec3::splat(30.0),
        ..point.clone()
    };
    scene_with(vec![point, spot])
}

#[test]
fn photon_budget_sets_view_resolutions_and_texel_offsets() {
    let scene = point_and_spot();
    let plan = BouncePlan::new(&scene, DVec3::new(0.0, 0.0, 5.0), &scene.bounds(), 60_000);
    assert_eq!(plan.views.len(), 7);
    // Every light gets about its share; the realised texels are at least the budget.
    let budget = photon_budget(&scene, 60_000);
    let point_texels: u32 = plan.extents[..6].iter().map(|(w, h)| w * h).sum();
    let spot_texels = plan.extents[6].0 * plan.extents[6].1;
    assert!(
        point_texels as usize >= budget[0],
        "{point_texels} < {}",
        budget[0]
    );
    assert!(
        spot_texels as usize >= budget[1],
        "{spot_texels} < {}",
        budget[1]
    );
    let mut offset = 0;
    for v in &plan.views {
        assert_eq!(v.texels.z as usize, offset);
        offset += (v.texels.x * v.texels.y) as usize;
    }
    assert_eq!(plan.texels, offset);
    assert_eq!(plan.view_lights, vec![0, 0, 0, 0, 0, 0, 1]);
    // No mirror or glass: no caustic view, every view keeps all of its texels.
    assert_eq!(plan.caustic_texels, 0);
    assert!(plan.views.iter().all(|v| v.kind.y == BOUNCE_VIEW_WHOLE));
}

#[test]
fn a_budget_past_the_largest_light_view_is_capped_and_said() {
    // The spot gets about a third of the budget in one view: 12 M photons ask for more
    // than 2048² texels there (5 M: 1369²), while the point light's six views stay below
    // the cap (5 M: 785² each).
    let scene = point_and_spot();
    let origin = DVec3::new(0.0, 0.0, 5.0);
    let plan = BouncePlan::new(&scene, origin, &scene.bounds(), 12_000_000);
    assert_eq!(plan.lights_at_max_resolution, vec![1]);
    assert_eq!(plan.extents[6], (MAX_RESOLUTION, MAX_RESOLUTION));
    assert!(plan.extents[..6].iter().all(|&(w, _)| w < MAX_RESOLUTION));
    let plan = BouncePlan::new(&scene, origin, &scene.bounds(), 60_000);
    assert!(plan.lights_at_max_resolution.is_empty());
}

/// Texels of view `v` of `plan` whose centre direction lies inside the spot's outer cone.
fn texels_in_cone(plan: &BouncePlan, v: usize, axis: DVec3, outer: f64) -> usize {
    let (w, h) = plan.extents[v];
    let inverse = plan.view_matrices[v].inverse();
    let mut n = 0;
    for y in 0..h {
        for x in 0..w {
            let ndc = texel_ndc(x, y, w, h);
            let d = unproject(&inverse, ndc, FAR) - unproject(&inverse, ndc, NEAR);
            n += usize::from(d.normalize().dot(axis) > outer.cos());
        }
    }
    n
}

#[test]
fn a_lights_views_are_compared_alone_and_in_place() {
    let scene = point_and_spot();
    let origin = DVec3::new(0.0, 0.0, 5.0);
    let plan = BouncePlan::new(&scene, origin, &scene.bounds(), 60_000);
    assert_eq!(plan.light_views(0), 0..6);
    assert_eq!(plan.light_views(1), 6..7);
    assert_eq!(plan.light_views(2), 0..0);
    let point = plan.texel_range(0..6);
    assert_eq!(point.start, 0);
    assert_eq!(plan.texel_range(6..7), point.end..plan.texels);
    // The spot turns: its views change, the point light's stay bit for bit.
    let mut turned = scene.clone();
    turned.lights[1].direction = Vec3::new(0.2, -1.0, 0.0).normalize();
    let moved = BouncePlan::new(&turned, origin, &scene.bounds(), 60_000);
    assert!(moved.same_light_views(&plan, 0));
    assert!(!moved.same_light_views(&plan, 1));
    // The point light brighter: both budgets (split by power) change.
    let mut brighter = scene.clone();
    brighter.lights[0].intensity *= 4.0;
    let brighter = BouncePlan::new(&brighter, origin, &scene.bounds(), 60_000);
    assert!(!brighter.same_light_views(&plan, 0));
    assert!(!brighter.same_light_views(&plan, 1));
    // Another origin moves every view.
    let elsewhere = BouncePlan::new(&scene, DVec3::ZERO, &scene.bounds(), 60_000);
    assert!(!elsewhere.same_light_views(&plan, 0));
}

#[test]
fn a_spot_lights_texels_inside_its_cone_match_its_budget() {
    // One view (outer cone 0.5) and a cube of six (outer cone 1.3).
    for outer in [0.5f32, 1.3] {
        let spot = Light {
            name: "s".into(),
            kind: LightKind::Spot {
                inner_cone_angle: outer * 0.6,
                outer_cone_angle: outer,
            },
            position: Vec3::ZERO,
            direction: Vec3::new(0.3, -1.0, 0.2).normalize(),
            intensity: Vec3::ONE,
        };
        let axis = spot.direction.as_dvec3();
        let scene = scene_with(vec![spot]);
        let plan = BouncePlan::new(&scene, DVec3::ZERO, &scene.bounds(), 40_000);
        let inside: usize = (0..plan.views.len())
            .map(|v| texels_in_cone(&plan, v, axis, f64::from(outer)))
            .sum();
        // Within the probe's accuracy and the rounding of the resolution.
        assert!(
            (40_000..43_000).contains(&inside),
            "outer {outer}: {inside} texels inside the cone of {} (budget 40000)",
            plan.texels
        );
    }
}

#[test]
fn inactive_lights_get_no_views_and_their_budget_goes_to_the_others() {
    let scene = point_and_spot();
    let camera = DVec3::new(0.0, 0.0, 5.0);
    let all = BouncePlan::new(&scene, camera, &scene.bounds(), 60_000);
    let spot_only = BouncePlan::with_budget(
        &scene,
        &[None, Some(60_000)],
        camera,
        &scene.bounds(),
        CAUSTIC_SHARE,
    );
    assert_eq!(spot_only.views.len(), 1);
    let res = spot_only.extents[0].0;
    assert!(res * res >= 60_000, "{res}² < the whole budget");
    assert!(res > all.extents[6].0, "the spot got no more photons");
    // The same light, the same seed and window: only the resolution changed.
    assert_eq!(spot_only.views[0].texels.w, all.views[6].texels.w);
    assert_eq!(spot_only.view_matrices[0], all.view_matrices[6]);
    assert_eq!(spot_only.texels, (res * res) as usize);
    let none = BouncePlan::with_budget(&scene, &[], camera, &scene.bounds(), CAUSTIC_SHARE);
    assert!(none.views.is_empty() && none.texels == 0);
}

#[test]
fn a_photon_start_lands_where_its_texel_ray_and_depth_say() {
    let light = Light {
        name: "p".into(),
        kind: LightKind::Point,
        position: Vec3::new(0.2, 0.1, -0.3),
        direction: Vec3::NEG_Y,
        intensity: Vec3::ONE,
    };
    let scene = scene_with(vec![light]);
    let camera = DVec3::new(1.0, 2.0, 5.0);
    let plan = BouncePlan::new(&scene, camera, &scene.bounds(), 600);
    let res = plan.extents[0].0;
    let mut map = vec![
        BounceMapPhoton {
            power: Vec3::ZERO,
            direction: Vec3::ZERO,
            eta: 1.0,
            depth: 0.0,
        };
        plan.texels
    ];
    let (x, y) = (res / 3, res / 2);
    map[(y * res + x) as usize] = BounceMapPhoton {
        power: Vec3::ONE,
        direction: crate::photon::types::pack_direction(Vec3::Y, 0.5),
        eta: 1.0,
        depth: 0.7,
    };
    let starts = plan.photon_starts(&map, 0);
    assert_eq!(starts.len(), 1);
    let from_light = starts[0].origin - Vec3::new(0.2, 0.1, -0.3);
    assert!(
        (from_light.length() - 0.7).abs() < 1e-3,
        "{}",
        from_light.length()
    );
}

/// A 2 m diffuse floor at y = 0 with a mirror ball of radius `r` at `centre`.
fn floor_and_mirror_ball(centre: Vec3, r: f32, lights: Vec<Light>) -> Scene {
    let floor = crate::photon::shapes::grid(4, |_, _| 0.0);
    let mut ball = crate::photon::shapes::icosphere(2);
    ball.material = 1;
    let mut s = crate::photon::shapes::scene_of(vec![
        (floor, glam::Mat4::from_scale(Vec3::splat(2.0))),
        (
            ball,
            glam::Mat4::from_scale_rotation_translation(
                Vec3::splat(r),
                glam::Quat::IDENTITY,
                centre,
            ),
        ),
    ]);
    s.materials.push(crate::scene::Material {
        lambertian: Vec3::ZERO,
        glossy: Vec3::ONE,
        exponent: f32::INFINITY,
        ..Default::default()
    });
    s.lights = lights;
    s
}

fn sun() -> Light {
    Light {
        name: "sun".into(),
        kind: LightKind::Directional,
        position: Vec3::ZERO,
        direction: Vec3::new(-0.6, -0.8, 0.1).normalize(),
        intensity: Vec3::splat(2.0),
    }
}

/// NDC of world point `p` in view `v` of `plan`.
fn project(plan: &BouncePlan, v: usize, p: Vec3) -> glam::DVec3 {
    let c = plan.view_matrices[v] * (p.as_dvec3() - plan.origin).extend(1.0);
    c.truncate() / c.w
}

#[test]
fn a_small_mirror_under_the_sun_gets_a_caustic_view_nested_in_the_main_view() {
    let scene = floor_and_mirror_ball(Vec3::new(0.3, 0.3, -0.2), 0.3, vec![sun()]);
    let camera = DVec3::new(0.5, 1.0, 2.0);
    let photons = 50_000;
    let plan = BouncePlan::new(&scene, camera, &scene.bounds(), photons);
    assert_eq!(plan.views.len(), 2, "{:?}", plan.extents);
    let (main, caustic) = (&plan.views[0], &plan.views[1]);
    assert_eq!(main.kind.y, BOUNCE_VIEW_PARENT);
    assert_eq!(caustic.kind.y, BOUNCE_VIEW_CAUSTIC);
    assert_eq!(caustic.kind.z, 0, "the parent is the main view");
    assert_eq!(plan.view_lights, vec![0, 0]);
    // The same light, seed and normalisation.
    assert_eq!(main.intensity, caustic.intensity);
    assert_eq!(main.texels.w, caustic.texels.w);
    // Whole parent texels, each split k × k: the corner sits on the parent's texel grid.
    let k = (main.params.x / caustic.params.x).round();
    assert!(k >= 2.0, "k = {k}");
    assert!((main.params.x / caustic.params.x - k).abs() < 1e-4);
    for axis in [2, 3] {
        let i0 = (caustic.params[axis] - main.params[axis]) / main.params.x;
        assert!(
            (i0 - i0.round()).abs() < 1e-3,
            "corner at {i0} parent texels"
        );
    }
    let (w, h) = plan.extents[1];
    assert!(w % k as u32 == 0 && h % k as u32 == 0, "{w}×{h}, k {k}");
    // Half of the budget, up to the rounding of k.
    let share = plan.caustic_texels as f64 / photons as f64;
    assert!((0.35..0.7).contains(&share), "caustic share {share}");
    // The ball projects into the window, and the window is tight around it: it covers a
    // few percent of the main view, and the ball's silhouette reaches within a parent
    // texel of its edges (the ball spans ≈ 17 main texels).
    let mut lo = glam::DVec2::splat(f64::INFINITY);
    let mut hi = -lo;
    for p in &scene.meshes[1].positions {
        let world = scene.instances[1].transform.transform_point3(*p);
        let ndc = project(&plan, 1, world);
        assert!(
            ndc.x.abs() <= 1.0 && ndc.y.abs() <= 1.0,
            "{world} outside: {ndc}"
        );
        lo = lo.min(ndc.truncate());
        hi = hi.max(ndc.truncate());
    }
    assert!(
        (hi - lo).min_element() > 1.5,
        "window not tight: ball spans {lo}..{hi}"
    );
    let area = f64::from(w * h) / f64::from(k * k) / f64::from(plan.extents[0].0.pow(2));
    assert!(area < 0.02, "window covers {area} of the main view");
}

#[test]
fn a_point_light_gets_caustic_views_on_the_faces_that_see_the_mirror_only() {
    // Point light just above the ball's top: the ball spans the −Y face and its four
    // neighbours (not +Y).
    let light = Light {
        name: "p".into(),
        kind: LightKind::Point,
        position: Vec3::new(0.0, 0.25, 0.0),
        direction: Vec3::NEG_Y,
        intensity: Vec3::ONE,
    };
    let scene = floor_and_mirror_ball(Vec3::new(0.0, 0.12, 0.0), 0.1, vec![light]);
    let plan = BouncePlan::new(&scene, DVec3::ZERO, &scene.bounds(), 60_000);
    let roles: Vec<u32> = plan.views.iter().map(|v| v.kind.y).collect();
    assert_eq!(&roles[..6], &[1, 1, 0, 1, 1, 1], "{roles:?}");
    let parents: Vec<u32> = plan.views[6..].iter().map(|v| v.kind.z).collect();
    assert_eq!(parents, vec![0, 1, 3, 4, 5]);
    assert!(plan.views[6..]
        .iter()
        .all(|v| v.kind.y == BOUNCE_VIEW_CAUSTIC));
}

#[test]
fn no_caustic_view_where_the_light_cannot_reach_the_mirror_or_the_share_is_zero() {
    let spot = Light {
        name: "s".into(),
        kind: LightKind::Spot {
            inner_cone_angle: 0.2,
            outer_cone_angle: 0.3,
        },
        position: Vec3::new(-0.8, 1.0, 0.0),
        direction: Vec3::NEG_Y,
        intensity: Vec3::ONE,
    };
    // The ball is 45° off the spot's axis, outside its 0.3 rad cone (and its view).
    let scene = floor_and_mirror_ball(Vec3::new(0.2, 0.1, 0.0), 0.1, vec![spot]);
    let plan = BouncePlan::new(&scene, DVec3::ZERO, &scene.bounds(), 20_000);
    assert_eq!(plan.views.len(), 1);
    assert_eq!(plan.views[0].kind.y, BOUNCE_VIEW_WHOLE);
    let lit = floor_and_mirror_ball(Vec3::new(0.2, 0.1, 0.0), 0.1, vec![sun()]);
    let off = BouncePlan::with_budget(&lit, &[Some(20_000)], DVec3::ZERO, &lit.bounds(), 0.0);
    assert_eq!(off.views.len(), 1);
    assert_eq!(off.views[0].kind.y, BOUNCE_VIEW_WHOLE);
    assert!(off.texels >= 20_000);
    let on = BouncePlan::new(&lit, DVec3::ZERO, &lit.bounds(), 20_000);
    assert_eq!(on.views.len(), 2);
}

#[test]
fn a_mirror_that_fills_the_lights_view_gets_no_caustic_view() {
    // A narrow spot aimed at a big ball right below it: the ball covers the whole view.
    let spot = Light {
        name: "s".into(),
        kind: LightKind::Spot {
            inner_cone_angle: 0.1,
            outer_cone_angle: 0.2,
        },
        position: Vec3::new(0.0, 1.2, 0.0),
        direction: Vec3::NEG_Y,
        intensity: Vec3::ONE,
    };
    let scene = floor_and_mirror_ball(Vec3::new(0.0, 0.5, 0.0), 0.5, vec![spot]);
    let plan = BouncePlan::new(&scene, DVec3::ZERO, &scene.bounds(), 20_000);
    assert_eq!(plan.views.len(), 1, "{:?}", plan.extents);
    assert_eq!(plan.views[0].kind.y, BOUNCE_VIEW_WHOLE);
}

#[test]
fn a_plan_emits_its_budget_not_whole_grids() {
    // A narrow spot (its cone a fraction of its square view) and the sun, each with a
    // mirror ball in its light (caustic views): the slots hold the budget, and the keep
    // probability brings them down to it.
    let spot = Light {
        name: "spot".into(),
        kind: LightKind::Spot {
            inner_cone_angle: 0.3,
            outer_cone_angle: 0.5,
        },
        position: Vec3::new(0.0, 2.0, 0.0),
        direction: Vec3::NEG_Y,
        intensity: Vec3::ONE,
    };
    for light in [spot, sun()] {
        let scene = floor_and_mirror_ball(Vec3::new(0.1, 0.3, 0.0), 0.3, vec![light]);
        for n in [1_000, 20_000] {
            let plan = BouncePlan::new(&scene, DVec3::ZERO, &scene.bounds(), n);
            assert!(plan.caustic_views() > 0, "{:?}", plan.extents);
            assert_eq!(plan.photons, n);
            assert!(plan.slots >= n && plan.texels > n, "{} slots", plan.slots);
            for view in &plan.views {
                let keep = f64::from(view.params.y);
                assert!((keep - n as f64 / plan.slots as f64).abs() < 1e-6, "{keep}");
            }
            let whole = plan.clone().whole_grids();
            assert!(whole.views.iter().all(|v| v.params.y == 1.0));
            assert_eq!(whole.photons, plan.slots);
        }
    }
}

#[test]
fn texels_are_kept_with_their_probability_over_texels_and_over_samples() {
    let keys: Vec<u32> = (0..20_000u32).map(|i| hash2(i, 7)).collect();
    for keep in [0.0f32, 0.37, 0.9, 1.0] {
        let kept = keys.iter().filter(|&&k| texel_kept(k, 3, keep)).count();
        let share = kept as f64 / keys.len() as f64;
        assert!((share - f64::from(keep)).abs() < 0.01, "{keep}: {share}");
        // One texel over 100 samples: the R1 rotation keeps it in that share of them,
        // to within a sample or two.
        let turns = (0..100).filter(|&s| texel_kept(keys[0], s, keep)).count();
        assert!(
            (turns as f64 - 100.0 * f64::from(keep)).abs() <= 2.0,
            "{keep}: {turns}"
        );
    }
}

#[test]
fn moved_lights_keep_their_caustic_views_within_the_capacity_reserved_for_them() {
    let scene = floor_and_mirror_ball(Vec3::new(0.3, 0.3, -0.2), 0.3, vec![sun()]);
    let (camera, bounds, all) = (DVec3::ZERO, scene.bounds(), [Some(50_000)]);
    let plan = BouncePlan::new(&scene, camera, &bounds, 50_000);
    let capacity = plan.capacity();
    assert!(capacity.holds(&plan));
    // Room for a caustic view per main view, and for 16/9 of the caustic share.
    assert_eq!(capacity.views, 2);
    assert!(capacity.texels >= plan.texels - plan.caustic_texels + 44_444);
    // The sun turns by a few degrees: the caustic view changes size, and still fits.
    for degrees in [-6.0f32, -3.0, 3.0, 6.0] {
        let mut moved = scene.clone();
        let turn = glam::Quat::from_rotation_y(degrees.to_radians());
        moved.lights[0].direction = turn * moved.lights[0].direction;
        let free = BouncePlan::new(&moved, camera, &bounds, 50_000);
        let within =
            BouncePlan::within(&moved, &all, camera, &bounds, 0.5, &capacity).expect("fits");
        assert!(capacity.holds(&free), "{degrees}°: {:?}", free.extents);
        assert_eq!(within.extents, free.extents, "{degrees}°");
    }
    // Buffers with room for a quarter of the caustic view: k is lowered until it fits, and
    // the main view is the budget's without the growth that made up for the window's
    // texels off the ball (module docs, "Budget"): the light emits fewer photons.
    let main = plan.texels - plan.caustic_texels;
    let small = Capacity {
        texels: main + plan.caustic_texels / 4,
        ..capacity
    };
    let fitted = BouncePlan::within(&scene, &all, camera, &bounds, 0.5, &small)
        .expect("fits with a smaller k");
    assert!(small.holds(&fitted));
    assert!(fitted.caustic_texels > 0 && fitted.caustic_texels < plan.caustic_texels);
    assert!(
        fitted.extents[0].0 <= plan.extents[0].0,
        "{:?}",
        fitted.extents
    );
    assert!(fitted.photons < 50_000 && plan.photons == 50_000);
    // No room for the caustic view at all: it goes, and the main view keeps that size (the
    // whole budget would not fit either).
    let fitted_main = fitted.texels - fitted.caustic_texels;
    let tiny = Capacity {
        texels: fitted_main,
        ..capacity
    };
    let alone =
        BouncePlan::within(&scene, &all, camera, &bounds, 0.5, &tiny).expect("the main view fits");
    assert_eq!(alone.extents, vec![fitted.extents[0]]);
    assert_eq!(alone.views[0].kind.y, BOUNCE_VIEW_WHOLE);
    // No room for the main view: an error naming the sizes.
    let none = Capacity {
        texels: fitted_main - 1,
        ..capacity
    };
    let err = BouncePlan::within(&scene, &all, camera, &bounds, 0.5, &none)
        .expect_err("the main view needs more texels");
    assert!(err.to_string().contains("light views"), "{err}");
}

#[test]
fn a_lights_seed_follows_its_name_not_its_place_or_position() {
    let light = |name: &str, x: f32| Light {
        name: name.into(),
        kind: LightKind::Point,
        position: Vec3::new(x, 1.0, 0.0),
        direction: Vec3::NEG_Y,
        intensity: Vec3::ONE,
    };
    let lights = [light("a", 0.0), light("b", 0.0), light("b", 2.0)];
    let seeds: Vec<u32> = (0..3).map(|i| light_seed(&lights, i)).collect();
    // Distinct for distinct names, and for two lights of one name.
    assert!(seeds[0] != seeds[1] && seeds[1] != seeds[2] && seeds[0] != seeds[2]);
    // Moved: the same seed; another light removed: the same seed.
    let moved = [light("a", 0.5), light("b", 0.0), light("b", 2.0)];
    assert_eq!(light_seed(&moved, 0), seeds[0]);
    assert_eq!(light_seed(&lights[1..], 0), seeds[1]);
}
