//! Image Space Photon Mapping on the GPU, end to end on lavapipe with validation on: the
//! bounce map carries exactly the lights' power, the photon volumes compute exactly what a CPU
//! gather computes from the same photons, and the statistics describe the buffers drawn.

mod common;

use glam::Vec3;
use ispm::frame::{FrameImage, Method, RenderSettings, Renderer};
use ispm::photon::bsdf::Bsdf;
use ispm::photon::kernel::{kernel_radius, kernel_weight, KernelSettings};
use ispm::photon::types::{unpack_direction, Photon};
use ispm::reference::scenes;
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

fn render(scene: &Scene, settings: RenderSettings) -> (Renderer, FrameImage) {
    let gpu = common::gpu();
    let mut renderer = Renderer::new(&gpu, scene, settings).expect("renderer");
    let frame = renderer.render().expect("render");
    common::assert_validation_clean(&gpu);
    (renderer, frame)
}

/// IEEE half → f32 (the G-buffer's normal and albedo are RGBA16F).
fn f16_to_f32(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = i32::from((h >> 10) & 0x1f);
    let frac = f32::from(h & 0x3ff);
    match exp {
        0 => sign * frac * 2f32.powi(-24),
        31 => sign * f32::INFINITY,
        e => sign * (1.0 + frac / 1024.0) * 2f32.powi(e - 15),
    }
}

fn rgba16f(bytes: &[u8]) -> Vec<Vec3> {
    bytes
        .chunks_exact(8)
        .map(|c| {
            let h = |i: usize| f16_to_f32(u16::from_le_bytes([c[i], c[i + 1]]));
            Vec3::new(h(0), h(2), h(4))
        })
        .collect()
}

/// The CPU gather of the same photons at the same surface points the GPU shaded: for every
/// pixel of the eye G-buffer, Σ f(s, ωi, ωo)·Φ·κ over the photon map, with the CPU über-BSDF
/// and the CPU kernel (`photon::kernel`), brute force.
fn cpu_gather(
    scene: &Scene,
    renderer: &Renderer,
    photons: &[Photon],
    kernel: KernelSettings,
) -> Vec<Vec3> {
    let position: Vec<[f32; 4]> =
        bytemuck::pod_collect_to_vec(&renderer.read_gbuffer("position").expect("position"));
    let normal = rgba16f(&renderer.read_gbuffer("normal").expect("normal"));
    let albedo = rgba16f(&renderer.read_gbuffer("albedo").expect("albedo"));
    let material: Vec<u32> =
        bytemuck::pod_collect_to_vec(&renderer.read_gbuffer("material").expect("material"));
    let unpacked: Vec<(Vec3, Vec3, Vec3, f32, f32, Vec3)> = photons
        .iter()
        .map(|p| {
            let (wi, rho) = unpack_direction(p.direction);
            // Camera-relative positions: the eye is at the origin.
            let (r_xy, r_z) = kernel_radius(rho, &kernel, p.position.length());
            (p.position, p.normal.normalize(), wi, r_xy, r_z, p.power)
        })
        .collect();
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
            let bsdf = Bsdf::new(&scene.materials[material[i] as usize], Some(albedo[i]));
            let mut sum = Vec3::ZERO;
            for &(x, np, wi, r_xy, r_z, power) in &unpacked {
                let kappa = kernel_weight(x, np, r_xy, r_z, s);
                if kappa > 0.0 && wi.dot(n) > 0.0 {
                    sum += bsdf.eval(wo, wi, n, n) * power * kappa;
                }
            }
            sum
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
    let cpu = cpu_gather(scene, renderer, photons.photon_map(), photons.kernel());
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
fn gpu_photon_volumes_equal_the_cpu_gather_of_the_same_photons() {
    let scene = ispm::scene::bundled::resolve(Some("cornell-box")).expect("scene");
    let (renderer, frame) = render(&scene, settings(64, 20_000));
    assert!(frame.stats.stored_photons > 5_000, "{:?}", frame.stats);
    let (worst, peak) = compare_with_cpu_gather(&scene, &renderer, "estimator_equivalence");
    assert!(peak > 0.0, "no indirect light at all");
    // Bound: 1e-3 of the brightest indirect pixel (f32 summation order and the GPU's pow/exp
    // differ from the CPU's; diffuse, glossy and Fresnel terms all take part).
    assert!(
        worst < 1e-3,
        "GPU vs CPU gather: worst error {worst} of peak {peak}"
    );
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
    let (renderer, frame) = render(
        &scene,
        RenderSettings {
            radius: Some(0.3),
            ..settings(32, 20_000)
        },
    );
    // Multi-bounce photons on the floor get r_max; their volumes reach r_z = r_max·NORMAL_RATIO
    // above it, far over the camera's 2 cm.
    let kernel = renderer.photons().expect("ispm").kernel();
    let reach = kernel.r_max * ispm::photon::kernel::NORMAL_RATIO;
    assert!(
        reach > 0.1,
        "the camera must sit inside the volumes: {kernel:?}"
    );
    let (worst, peak) = compare_with_cpu_gather(&scene, &renderer, "camera_inside_volume");
    assert!(peak > 0.0, "no indirect light reached the floor");
    assert!(
        worst < 1e-3,
        "inside the volumes: worst error {worst} of peak {peak}"
    );
    // Every pixel sees the floor and gets indirect light: no dark blotch.
    let dark = frame.hdr.chunks_exact(4).filter(|p| p[0] <= 0.0).count();
    assert_eq!(dark, 0, "{dark} black pixels");
}

fn bounce_map_power(scene: &Scene) -> Vec3 {
    // Albedo 1 and Lambertian: every photon survives the first bounce with weight 1, so the
    // bounce map carries exactly what the light emitted.
    let (renderer, _) = render(scene, settings(16, 30_000));
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
    for (inner, outer) in [(0.2, 0.4), (0.9, 1.3)] {
        let mut scene = scenes::grey_box(1.0, 1.0);
        scene.lights = vec![Light {
            name: "spot".into(),
            kind: LightKind::Spot {
                inner_cone_angle: inner,
                outer_cone_angle: outer,
            },
            position: Vec3::new(0.0, 0.5, 0.0),
            direction: Vec3::new(0.2, -1.0, 0.1).normalize(),
            intensity: Vec3::splat(3.0),
        }];
        let total = bounce_map_power(&scene);
        let flux =
            3.0 * std::f32::consts::TAU * ispm::photon::emit::spot_falloff_integral(inner, outer);
        assert!(
            ((total.x - flux) / flux).abs() < 1e-4,
            "cone {inner}..{outer}: {total} vs {flux}"
        );
    }
}

#[test]
fn stats_describe_the_photon_buffers_drawn() {
    let scene = ispm::scene::bundled::resolve(Some("cornell-box")).expect("scene");
    let (renderer, frame) = render(&scene, settings(32, 10_000));
    let photons = renderer.photons().expect("ispm");
    let s = &frame.stats;
    assert_eq!(s.emitted_photons, photons.bounce_map().len());
    assert!(s.emitted_photons >= 10_000, "{s:?}");
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
        "photon_volumes",
    ] {
        assert!(
            s.passes_run.iter().any(|p| p == pass),
            "{pass} missing from {:?}",
            s.passes_run
        );
    }
    let json = ispm::stats::frame_json(&scene, &frame, renderer.triangles(), 8, 0);
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
    for stage in ispm::stats::STAGES {
        assert!(json["ms"][stage].is_number(), "no time for {stage}");
    }
}
