//! Image Space Photon Mapping on the GPU, end to end on lavapipe with validation on: the
//! bounce map carries exactly the lights' power, both density estimators compute exactly what a CPU
//! gather computes from the same photons, and the statistics describe the buffers drawn.

mod common;

use glam::Vec3;
use ispm::config::settings::{Density, Method, RenderSettings};
use ispm::layout::shared_constants::{
    CAUSTIC_PATH_DENSITY, LIGHT_VIEW_FAR_Z, LIGHT_VIEW_NEAR_Z, SUPPORT_FRACTION_MIN,
    SUPPORT_NORMAL_COS,
};
use ispm::photon::bsdf::Bsdf;
use ispm::photon::density::PhotonClass;
use ispm::photon::kernel::{kernel_radius, kernel_t, kernel_weight, KernelSettings};
use ispm::photon::types::{unpack_direction, unpack_normal, Photon};
use ispm::reference::scenes;
use ispm::render::frame::Renderer;
use ispm::render::stats::FrameImage;
use ispm::scene::{Camera, Light, LightKind, Scene};

fn settings(size: u32, photons: usize) -> RenderSettings {
    RenderSettings {
        method: Method::Ispm,
        photons,
        width: size,
        height: size,
        shadow_resolution: 256,
        ..Default::default()
    }
}

/// [`settings`] with every light-view texel sending its photon, so that the bounce map carries
/// each light's flux exactly in every frame (`RenderSettings::whole_light_grids`). One bounce:
/// these tests read the bounce map only, and in the boxes of albedo 1 they use Russian roulette
/// never ends a path, so the default cap (256 bounces) would trace 256 times the photons.
fn whole_grids(size: u32, photons: usize) -> RenderSettings {
    RenderSettings {
        whole_light_grids: true,
        bounces: 1,
        ..settings(size, photons)
    }
}

fn render(scene: &Scene, settings: RenderSettings) -> (Renderer, FrameImage) {
    let gpu = common::gpu();
    let mut renderer = Renderer::new(&gpu, scene, settings).expect("renderer");
    let frame = renderer.render().expect("render");
    common::assert_validation_clean(&gpu);
    (renderer, frame)
}

/// The RGB of an RGBA16F image read back (the G-buffer's normal and albedo).
fn rgba16f(bytes: &[u8]) -> Vec<Vec3> {
    bytes
        .chunks_exact(8)
        .map(|c| {
            let h = |i: usize| common::f16_to_f32(u16::from_le_bytes([c[i], c[i + 1]]));
            Vec3::new(h(0), h(2), h(4))
        })
        .collect()
}

/// Each photon of a drawn photon map (`PhotonFrame::photon_map`: normals packed with the kNN
/// radii) as the photon volumes see it: position, unit normal, incident direction, `r_xy`,
/// `r_z` (`photon::kernel`, the eye at the origin), power, and whether it is a global photon
/// (`ρp ≤ CAUSTIC_PATH_DENSITY`: normalised by the support pass, kept to its own surface).
type DrawnKernel = (Vec3, Vec3, Vec3, f32, f32, Vec3, bool);

fn drawn_kernels(photons: &[Photon], kernel: &KernelSettings) -> Vec<DrawnKernel> {
    photons
        .iter()
        .map(|p| {
            let (wi, rho_p) = unpack_direction(p.direction);
            let (n, r_knn) = unpack_normal(p.normal);
            // Camera-relative positions: the eye is at the origin.
            let (r_xy, r_z) = kernel_radius(r_knn, kernel, p.position.length());
            let global = rho_p <= CAUSTIC_PATH_DENSITY || rho_p.is_nan();
            (p.position, n, wi, r_xy, r_z, p.power, global)
        })
        .collect()
}

/// The CPU gather of the same photons at the same surface points the GPU shaded: for every
/// pixel of the eye G-buffer, Σ f(s, ωi, ωo)·Φ·κ over the photon map, with the CPU über-BSDF
/// and the CPU kernel (`photon::kernel`, each photon's radius from its packed normal), brute
/// force. A global photon reaches only surfaces within `SUPPORT_NORMAL_COS` of its normal, and
/// the global photons' sum at a pixel is divided by `max(f, SUPPORT_FRACTION_MIN)`, `f` the
/// share of the kernel on the surface that the GPU's support pass measured there
/// (`passes/support.rs`; the measurement itself is checked against the path tracer in
/// `tests/progressive.rs`, this checks everything else).
fn cpu_gather(
    scene: &Scene,
    renderer: &Renderer,
    photons: &[Photon],
    kernel: KernelSettings,
) -> Vec<Vec3> {
    let fraction = renderer
        .photons()
        .expect("ispm")
        .read_support_fraction()
        .expect("support fraction");
    let position: Vec<[f32; 4]> =
        bytemuck::pod_collect_to_vec(&renderer.read_gbuffer("position").expect("position"));
    let normal = rgba16f(&renderer.read_gbuffer("normal").expect("normal"));
    let albedo = rgba16f(&renderer.read_gbuffer("albedo").expect("albedo"));
    let material: Vec<u32> =
        bytemuck::pod_collect_to_vec(&renderer.read_gbuffer("material").expect("material"));
    let unpacked = drawn_kernels(photons, &kernel);
    position
        .iter()
        .enumerate()
        .map(|(i, pos)| {
            if pos[3] == 0.0 {
                return Vec3::ZERO;
            }
            let s = Vec3::new(pos[0], pos[1], pos[2]);
            let n = normal[i].normalize();
            let wo = (-s).normalize();
            let bsdf = Bsdf::new(&scene.materials[material[i] as usize], Some(albedo[i]))
                .regularized(kernel.gather_exponent_max());
            let (mut caustic, mut global) = (Vec3::ZERO, Vec3::ZERO);
            for &(x, np, wi, r_xy, r_z, power, is_global) in &unpacked {
                if is_global && np.dot(n).abs() < SUPPORT_NORMAL_COS {
                    continue;
                }
                let kappa = kernel_weight(x, np, r_xy, r_z, s);
                if kappa > 0.0 && wi.dot(n) > 0.0 {
                    let c = bsdf.eval(wo, wi, n, n) * power * kappa;
                    if is_global {
                        global += c;
                    } else {
                        caustic += c;
                    }
                }
            }
            match &fraction {
                Some(f) if global != Vec3::ZERO => {
                    caustic + global / f[i].max(SUPPORT_FRACTION_MIN)
                }
                _ => caustic + global,
            }
        })
        .collect()
}

/// Compares the GPU's indirect buffer with the CPU gather; returns the largest error relative
/// to the image's brightest indirect pixel.
fn compare_with_cpu_gather(scene: &Scene, renderer: &Renderer, test: &str) -> (f32, f32) {
    let photons = renderer.photons().expect("ispm");
    let gpu: Vec<[f32; 4]> = photons
        .read_indirect()
        .expect("indirect")
        .chunks_exact(4)
        .map(|c| [c[0], c[1], c[2], c[3]])
        .collect();
    let cpu = cpu_gather(scene, renderer, &photons.photon_map(), photons.kernel());
    let peak = cpu.iter().map(|v| v.max_element()).fold(0.0f32, f32::max);
    let mut worst = 0.0f32;
    for (g, c) in gpu.iter().zip(&cpu) {
        let g = Vec3::new(g[0], g[1], g[2]);
        worst = worst.max((g - *c).abs().max_element() / peak.max(1e-30));
    }
    if worst > 1e-3 {
        let dir = common::image_dir(test);
        let size = renderer.width();
        let to_rgba = |v: &[Vec3]| {
            v.iter()
                .flat_map(|p| [p.x, p.y, p.z, 1.0])
                .collect::<Vec<f32>>()
        };
        let gpu3: Vec<Vec3> = gpu.iter().map(|g| Vec3::new(g[0], g[1], g[2])).collect();
        let diff: Vec<Vec3> = gpu3
            .iter()
            .zip(&cpu)
            .map(|(g, c)| (*g - *c).abs())
            .collect();
        for (name, img) in [("actual", &gpu3), ("expected", &cpu), ("difference", &diff)] {
            let path = dir.join(format!("{name}.exr"));
            ispm::output::write_exr(&path, size, size, &to_rgba(img)).expect("exr");
            eprintln!("wrote {}", path.display());
        }
    }
    (worst, peak)
}

#[test]
fn gpu_density_estimates_equal_the_cpu_gather_of_the_same_photons() {
    // Both estimators: the photon volumes (splatted by the rasteriser) and the tiled gather.
    let scene = ispm::scene::bundled::resolve(Some("cornell-box")).expect("scene");
    for density in [Density::Volumes, Density::Tiled] {
        let (renderer, frame) = render(
            &scene,
            RenderSettings {
                density,
                ..settings(64, 20_000)
            },
        );
        assert!(frame.stats.stored_photons > 5_000, "{:?}", frame.stats);
        let test = format!("estimator_equivalence_{density:?}");
        let (worst, peak) = compare_with_cpu_gather(&scene, &renderer, &test);
        assert!(peak > 0.0, "{density:?}: no indirect light at all");
        // Bound: 1e-3 of the brightest indirect pixel (f32 summation order and the GPU's
        // pow/exp differ from the CPU's; diffuse, glossy and Fresnel terms all take part).
        assert!(
            worst < 1e-3,
            "{density:?} vs CPU gather: worst error {worst} of peak {peak}"
        );
    }
}

#[test]
fn camera_inside_a_photon_volume_keeps_indirect_light() {
    // Camera 2 cm above the floor of a closed grey box, looking down: far inside the kernels
    // of the photons stored on the floor (r_max is tens of centimetres here).
    let mut scene = scenes::grey_box(0.5, 4.0);
    let eye = Vec3::new(0.1, -0.98, 0.05);
    scene.camera = Camera {
        transform: glam::camera::rh::view::look_at_mat4(eye, eye + Vec3::NEG_Y, Vec3::Z).inverse(),
        yfov: 60f32.to_radians(),
        znear: 1e-3,
        zfar: None,
    };
    for density in [Density::Volumes, Density::Tiled] {
        camera_inside_kernels(&scene, density);
    }
}

fn camera_inside_kernels(scene: &Scene, density: Density) {
    let (renderer, frame) = render(
        scene,
        RenderSettings {
            radius: Some(0.3),
            density,
            ..settings(32, 20_000)
        },
    );
    // The floor's photons have kNN radii of several centimetres here (20k photons over a 2 m
    // box); their volumes reach r_z = r_xy·NORMAL_RATIO above it, over the camera's 2 cm: the
    // eye lies inside 43 of them (measured).
    let photons = renderer.photons().expect("ispm");
    let kernel = photons.kernel();
    let around_eye = drawn_kernels(&photons.photon_map(), &kernel)
        .iter()
        .filter(|&&(x, n, _, r_xy, r_z, _, _)| kernel_t(x, n, r_xy, r_z, Vec3::ZERO) < 1.0)
        .count();
    assert!(
        around_eye >= 10,
        "the camera must sit inside the volumes: {around_eye} contain it ({kernel:?})"
    );
    let test = format!("camera_inside_volume_{density:?}");
    let (worst, peak) = compare_with_cpu_gather(scene, &renderer, &test);
    assert!(
        peak > 0.0,
        "{density:?}: no indirect light reached the floor"
    );
    assert!(
        worst < 1e-3,
        "{density:?}, inside the volumes: worst error {worst} of peak {peak}"
    );
    // Every pixel sees the floor and gets indirect light: no dark blotch.
    let dark = frame.hdr.chunks_exact(4).filter(|p| p[0] <= 0.0).count();
    assert_eq!(dark, 0, "{density:?}: {dark} black pixels");
}

#[test]
fn drawn_photons_carry_their_kth_nearest_neighbour_distance_in_their_normal() {
    // cornell-box has both classes: photons through the glass sphere (caustic) and the room's
    // diffuse interreflection (global).
    let scene = ispm::scene::bundled::resolve(Some("cornell-box")).expect("scene");
    let (renderer, frame) = render(&scene, settings(32, 20_000));
    let photons = renderer.photons().expect("ispm");
    let map = photons.photon_map();
    assert_eq!(map.len(), frame.stats.stored_photons);
    let neighbours = photons.neighbours();
    let class = |p: &Photon| PhotonClass::of(unpack_direction(p.direction).1);
    let caustic = map
        .iter()
        .filter(|p| class(p) == PhotonClass::Caustic)
        .count();
    assert!(
        caustic > neighbours.caustic && map.len() - caustic > neighbours.global,
        "{caustic} caustic photons of {}",
        map.len()
    );
    // Brute force on every 97th photon: the distance to its k-th nearest neighbour among the
    // photons of its class (the map is eye-relative, the radii were measured origin-relative:
    // the same distances to f32 rounding).
    let mut checked = 0;
    for p in map.iter().step_by(97) {
        let (n, r) = unpack_normal(p.normal);
        assert!((n.length() - 1.0).abs() < 1e-5, "{p:?}");
        let c = class(p);
        let mut d: Vec<f32> = map
            .iter()
            .filter(|q| class(q) == c)
            .map(|q| q.position.distance(p.position))
            .collect();
        d.sort_by(f32::total_cmp);
        // d[0] is the photon itself.
        let expected = d[neighbours.of(c)];
        assert!(
            (r - expected).abs() <= 1e-4 * expected + 2e-6,
            "{c:?} photon at {}: packed radius {r}, k-th neighbour at {expected}",
            p.position
        );
        checked += 1;
    }
    assert!(checked > 100, "{checked}");
}

fn bounce_map_power(scene: &Scene) -> Vec3 {
    // Albedo 1 and Lambertian: every photon survives the first bounce with weight 1, so the
    // bounce map carries exactly what the light emitted.
    let (renderer, _) = render(scene, whole_grids(16, 30_000));
    renderer
        .photons()
        .expect("ispm")
        .bounce_map()
        .iter()
        .fold(Vec3::ZERO, |a, p| a + p.power)
}

#[test]
fn bounce_map_power_sums_to_a_point_lights_flux() {
    let intensity = 2.5;
    let scene = scenes::grey_box(1.0, intensity);
    let total = bounce_map_power(&scene);
    let flux = 4.0 * std::f32::consts::PI * intensity;
    assert!(((total.x - flux) / flux).abs() < 1e-4, "{total} vs {flux}");
}

#[test]
fn bounce_map_power_sums_to_a_spot_lights_flux() {
    // One view and a cube of six; without and with a mirror ball in the cone (caustic views).
    for (inner, outer) in [(0.2, 0.4), (0.9, 1.3)] {
        for ball in [false, true] {
            let mut scene = scenes::grey_box(1.0, 1.0);
            let direction = Vec3::new(0.2, -1.0, 0.1).normalize();
            scene.lights = vec![Light {
                name: "spot".into(),
                kind: LightKind::Spot {
                    inner_cone_angle: inner,
                    outer_cone_angle: outer,
                },
                position: Vec3::new(0.0, 0.5, 0.0),
                direction,
                intensity: Vec3::splat(3.0),
            }];
            if ball {
                scene = with_mirror_ball(scene, Vec3::new(0.0, 0.5, 0.0) + direction * 0.9, 0.2);
            }
            let (renderer, _) = render(&scene, whole_grids(16, 30_000));
            let (total, mirror, caustic) = bounce_map_power_by_role(&renderer);
            let flux = 3.0
                * std::f64::consts::TAU
                * f64::from(ispm::photon::emit::spot_falloff_integral(inner, outer));
            eprintln!(
                "spot {inner}..{outer}, mirror ball {ball}: {total:.6} W of {flux:.6} W \
                 (relative error {:.1e}), {mirror:.6} W off the mirror",
                (total - flux) / flux
            );
            let views = renderer.photons().expect("ispm").plan().views.len();
            assert_eq!(
                ball,
                views > if outer > 1.0 { 6 } else { 1 },
                "{views} views"
            );
            assert_eq!(mirror, caustic, "mirror photons from the main views");
            assert_eq!(ball, mirror > 0.0);
            assert!(
                ((total - flux) / flux).abs() < 1e-4,
                "cone {inner}..{outer}, mirror ball {ball}: {total} vs {flux}"
            );
        }
    }
}

/// `scene` with a perfect mirror ball (reflectance 1, so the bounce map keeps its power too) of
/// radius `r` at `centre`.
fn with_mirror_ball(mut scene: Scene, centre: Vec3, r: f32) -> Scene {
    scene.materials.push(ispm::scene::Material {
        name: "mirror".into(),
        lambertian: Vec3::ZERO,
        glossy: Vec3::ONE,
        exponent: f32::INFINITY,
        ..Default::default()
    });
    let mut ball = ispm::photon::shapes::icosphere(4);
    ball.material = scene.materials.len() - 1;
    scene.meshes.push(ball);
    scene.instances.push(ispm::scene::Instance {
        name: "mirror-ball".into(),
        mesh: scene.meshes.len() - 1,
        transform: glam::Mat4::from_scale_rotation_translation(
            Vec3::splat(r),
            glam::Quat::IDENTITY,
            centre,
        ),
    });
    scene
}

/// The bounce map's power in f64: in all, reflected by the mirror (ρp ≈ 1, not ρ/1000 as off a
/// diffuse surface), and reflected by the mirror from texels of the caustic views.
fn bounce_map_power_by_role(renderer: &Renderer) -> (f64, f64, f64) {
    let photons = renderer.photons().expect("ispm");
    let (map, plan) = (photons.bounce_map(), photons.plan());
    let (mut all, mut mirror, mut caustic) = (0.0, 0.0, 0.0);
    for view in &plan.views {
        let first = view.texels.z as usize;
        for p in &map[first..first + (view.texels.x * view.texels.y) as usize] {
            let power = f64::from(p.power.x);
            all += power;
            if unpack_direction(p.direction).1 > 0.5 {
                mirror += power;
                if view.kind.y == ispm::layout::shared_constants::BOUNCE_VIEW_CAUSTIC {
                    caustic += power;
                }
            }
        }
    }
    (all, mirror, caustic)
}

/// The bounce map carries `flux` (to `tolerance`, relative), and its mirror photons carry `ball`
/// (to 1 %), all of them from the caustic views.
fn assert_flux_and_mirror(
    what: &str,
    (total, mirror, caustic): (f64, f64, f64),
    (flux, tolerance): (f64, f64),
    ball: f64,
) {
    eprintln!(
        "{what}: bounce map {total:.6} W of {flux:.6} W (relative error {:.1e}); mirror \
         {mirror:.6} W ({caustic:.6} W from caustic views) of {ball:.6} W",
        (total - flux) / flux
    );
    assert!(
        ((total - flux) / flux).abs() < tolerance,
        "{what}: {total} vs {flux} ({mirror} off the mirror)"
    );
    assert_eq!(
        mirror, caustic,
        "{what}: mirror photons from the main views"
    );
    assert!(
        (mirror / ball - 1.0).abs() < 0.01,
        "{what}: the mirror reflects {mirror}, the ball intercepts {ball}"
    );
}

#[test]
fn bounce_map_power_sums_to_a_point_lights_flux_with_caustic_views() {
    // A mirror ball 0.6 m from the light inside the closed white box: its caustic views take
    // the directions towards the ball, the six main views everything else.
    let intensity = 2.5;
    let (centre, r) = (Vec3::new(0.3, -0.5, 0.2), 0.25);
    let scene = with_mirror_ball(scenes::grey_box(1.0, intensity), centre, r);
    let (renderer, _) = render(&scene, whole_grids(16, 30_000));
    let plan = renderer.photons().expect("ispm").plan();
    assert!(plan.views.len() > 6, "no caustic view: {:?}", plan.extents);
    let flux = 4.0 * std::f64::consts::PI * f64::from(intensity);
    // The mirror reflects what reaches it: I·2π(1 − cos θ), sin θ = r/d (the 2562-vertex
    // icosphere is inscribed in the sphere: 0.3 % less solid angle), all of it from the caustic
    // views.
    let sin = f64::from(r / centre.length());
    let ball = f64::from(intensity) * std::f64::consts::TAU * (1.0 - (1.0 - sin * sin).sqrt());
    let power = bounce_map_power_by_role(&renderer);
    assert_flux_and_mirror("point light", power, (flux, 1e-4), ball);
}

#[test]
fn bounce_map_power_of_the_sun_is_its_irradiance_times_the_texels_it_lights_with_caustic_views() {
    // A white floor (albedo 1) with a mirror ball on it, under the sun at 40° elevation.
    let mut scene = with_mirror_ball(scenes::grey_box(1.0, 1.0), Vec3::new(0.2, -0.7, 0.1), 0.3);
    scene
        .instances
        .retain(|i| i.name == "mirror-ball" || i.mesh == 2);
    let irradiance = 2.0f32;
    let elevation = 40f32.to_radians();
    scene.lights = vec![Light {
        name: "sun".into(),
        kind: LightKind::Directional,
        position: Vec3::ZERO,
        direction: Vec3::new(-elevation.cos(), -elevation.sin(), 0.3).normalize(),
        intensity: Vec3::splat(irradiance),
    }];
    let (renderer, _) = render(&scene, whole_grids(16, 30_000));
    let plan = renderer.photons().expect("ispm").plan();
    assert_eq!(plan.views.len(), 2, "no caustic view: {:?}", plan.extents);
    // Every main texel whose centre ray hits the scene carries E·(texel area), each exactly once:
    // either itself, or as the k² texels of the caustic view inside it.
    let bvh = ispm::photon::bvh::SceneBvh::new(&scene);
    let res = plan.extents[0].0;
    let inverse = plan.view_matrices[0].inverse();
    let point = |x: f64, y: f64, z: f64| {
        let h = inverse * glam::DVec4::new(x, y, z, 1.0);
        h.truncate() / h.w + plan.origin
    };
    let mut lit = 0usize;
    for y in 0..res {
        for x in 0..res {
            let ndc = |t: u32| (f64::from(t) + 0.5) / f64::from(res) * 2.0 - 1.0;
            let (near, far) = (
                point(ndc(x), ndc(y), f64::from(LIGHT_VIEW_NEAR_Z)),
                point(ndc(x), ndc(y), f64::from(LIGHT_VIEW_FAR_Z)),
            );
            let ray =
                ispm::photon::ray::Ray::new(near.as_vec3(), (far - near).normalize().as_vec3());
            lit += usize::from(bvh.intersect(&ray).is_some());
        }
    }
    let side = f64::from(plan.views[0].params.x);
    let expected = f64::from(irradiance) * side * side * lit as f64;
    // The ball's shadow area, E·πr², reaches the mirror.
    let ball = f64::from(irradiance) * std::f64::consts::PI * 0.09;
    let power = bounce_map_power_by_role(&renderer);
    // To 10⁻⁴, and a texel: one whose centre ray grazes the floor's edge may hit it in the BVH
    // and miss it in the rasteriser (or the other way).
    assert_flux_and_mirror(
        &format!("sun ({lit} lit texels of {res}²)"),
        power,
        (expected, 1e-4 + 1.0 / lit as f64),
        ball,
    );
}

#[test]
fn lights_emit_the_photons_asked_for_not_whole_grids() {
    // Two spots (cones in square views), a glass sphere and a mirror ring (caustic views, whose
    // photons depend on what their texels see): the photons sent are the budget to within 1 %,
    // every frame, though the light views hold more texels.
    for name in ["cornell-box", "glass-sphere", "caustic-ring"] {
        let scene = ispm::scene::bundled::resolve(Some(name)).expect("scene");
        for photons in [3_000, 30_000] {
            let gpu = common::gpu();
            let accumulate = RenderSettings {
                accumulate: true,
                ..settings(32, photons)
            };
            let mut renderer = Renderer::new(&gpu, &scene, accumulate).expect("renderer");
            for sample in 0..2 {
                let frame = renderer.render().expect("frame");
                let s = &frame.stats;
                let error = s.emitted_photons as f64 / photons as f64 - 1.0;
                eprintln!(
                    "{name}, {photons} photons, frame {sample}: {} sent ({:+.2} %) from {} \
                     texels",
                    s.emitted_photons,
                    100.0 * error,
                    s.bounce_map_records
                );
                assert!(
                    error.abs() <= 0.01,
                    "{name}: {} of {photons}",
                    s.emitted_photons
                );
                assert!(s.bounce_map_records > s.emitted_photons, "{s:?}");
            }
            common::assert_validation_clean(&gpu);
        }
    }
}

#[test]
fn stats_describe_the_photon_buffers_drawn() {
    let scene = ispm::scene::bundled::resolve(Some("cornell-box")).expect("scene");
    let (renderer, frame) = render(&scene, settings(32, 10_000));
    let photons = renderer.photons().expect("ispm");
    let s = &frame.stats;
    assert_eq!(s.bounce_map_records, photons.bounce_map().len());
    let sent = photons.bounce_map().iter().filter(|p| p.eta != 0.0).count();
    assert_eq!(s.emitted_photons, sent);
    let surviving = photons
        .bounce_map()
        .iter()
        .filter(|p| p.power.max_element() > 0.0)
        .count();
    assert_eq!(s.bounce_map_photons, surviving);
    assert_eq!(s.stored_photons, photons.photon_map().len());
    // attrition[k]: photons alive after bounce k; the bounce map is bounce 1.
    assert_eq!(s.attrition.get(1).copied(), Some(surviving as u64));
    for pass in [
        "light_gbuffers",
        "bounce_map",
        "readback",
        "upload",
        common::estimator_pass(),
    ] {
        assert!(
            s.passes_run.iter().any(|p| p == pass),
            "{pass} missing from {:?}",
            s.passes_run
        );
    }
    let json = ispm::render::stats::frame_json(&scene, &frame, renderer.triangles(), 8, 0);
    for key in [
        "triangles",
        "lights",
        "emitted_photons",
        "bounce_map_photons",
        "stored_photons",
        "bounces",
        "width",
        "height",
        "subsample",
        "ms",
        "passes_run",
        "validation_messages",
    ] {
        assert!(json.get(key).is_some(), "stats JSON lacks {key}");
    }
    for stage in ispm::render::stats::stages()
        .map(|s| s.name())
        .chain(["frame"])
    {
        assert!(json["ms"][stage].is_number(), "no time for {stage}");
    }
    // The kernel the estimate used, with the glossy regularisation's cap.
    let kernel = renderer.photons().expect("ispm").kernel();
    assert_eq!(
        json["kernel"]["r_max"].as_f64(),
        Some(f64::from(kernel.r_max))
    );
    assert_eq!(
        json["kernel"]["gather_exponent_max"].as_f64(),
        Some(f64::from(kernel.gather_exponent_max()))
    );
}
