//! Headless renders of the bundled scenes on the GPU, validation on: direct light where the
//! assertions are about direct light, both methods where they hold for any image.

mod common;

use glam::{Vec2, Vec3};
use ispm::config::settings::{Method, RenderSettings};
use ispm::render::frame::Renderer;
use ispm::render::stats::FrameImage;
use ispm::scene::bundled;

const SIZE: u32 = 128;

fn render(scene: &ispm::scene::Scene, method: Method) -> FrameImage {
    let gpu = common::gpu();
    let frame = {
        let mut r = Renderer::new(
            &gpu,
            scene,
            RenderSettings {
                method,
                photons: 20_000,
                width: SIZE,
                height: SIZE,
                shadow_resolution: 512,
                ..Default::default()
            },
        )
        .expect("renderer");
        r.render().expect("render")
    };
    common::assert_validation_clean(&gpu);
    frame
}

/// Mean linear RGB over a 3×3 block around the pixel where world point `p` lands.
fn radiance_at(scene: &ispm::scene::Scene, frame: &FrameImage, p: Vec3) -> Vec3 {
    let px: Vec2 = scene
        .camera
        .project_to_pixel(p, frame.width, frame.height)
        .expect("point in front of the camera");
    let (cx, cy) = (px.x as i32, px.y as i32);
    let mut sum = Vec3::ZERO;
    for dy in -1..=1 {
        for dx in -1..=1 {
            let x = (cx + dx).clamp(0, frame.width as i32 - 1) as usize;
            let y = (cy + dy).clamp(0, frame.height as i32 - 1) as usize;
            let i = (y * frame.width as usize + x) * 4;
            sum += Vec3::new(frame.hdr[i], frame.hdr[i + 1], frame.hdr[i + 2]);
        }
    }
    sum / 9.0
}

fn save(test: &str, frame: &FrameImage) -> std::path::PathBuf {
    let dir = common::image_dir(test);
    let png = dir.join("actual.png");
    ispm::output::write_png(&png, frame.width, frame.height, &frame.ldr).expect("png");
    ispm::output::write_exr(
        &dir.join("actual.exr"),
        frame.width,
        frame.height,
        &frame.hdr,
    )
    .expect("exr");
    png
}

#[test]
fn cornell_box_direct_light_is_validation_clean_lit_where_aimed_and_shadowed_behind_objects() {
    let scene = bundled::resolve(Some("cornell-box")).expect("bundled scene");
    let frame = render(&scene, Method::Direct);
    let path = save("cornell_box_direct", &frame);
    let at = |p| radiance_at(&scene, &frame, p);

    // Under each spot: lit; the blue spot's light is blue.
    let under_white = at(Vec3::new(-0.4, 0.0, 0.1));
    let under_blue = at(Vec3::new(0.55, 0.0, 0.1));
    assert!(
        under_white.min_element() > 0.1,
        "floor under the white spot: {under_white} ({})",
        path.display()
    );
    assert!(
        under_blue.z > 0.1 && under_blue.z > 1.5 * under_blue.x,
        "floor under the blue spot: {under_blue} ({})",
        path.display()
    );

    // Behind the glass sphere, seen from both spots: in shadow.
    let shadowed = at(Vec3::new(0.16, 0.0, 0.42));
    let lit_nearby = at(Vec3::new(-0.4, 0.0, 0.42));
    assert!(
        shadowed.length() < 0.25 * lit_nearby.length(),
        "shadow of the glass sphere {shadowed} vs lit floor {lit_nearby} ({})",
        path.display()
    );

    // Wall colours: the red wall is red, the green wall green.
    let left = at(Vec3::new(-1.0, 0.3, 0.0));
    let right = at(Vec3::new(1.0, 0.3, 0.0));
    assert!(
        left.x > 2.0 * left.y && left.x > 2.0 * left.z,
        "left wall {left} ({})",
        path.display()
    );
    assert!(
        right.y > 1.5 * right.x && right.y > 1.5 * right.z,
        "right wall {right} ({})",
        path.display()
    );
}

#[test]
fn every_bundled_scene_renders_finite_non_negative_radiance_and_round_trips_through_exr() {
    for (name, method) in bundled::BUNDLED
        .iter()
        .flat_map(|n| [(n, Method::Direct), (n, Method::Ispm)])
    {
        let scene = bundled::resolve(Some(name)).expect("bundled scene");
        let frame = render(&scene, method);
        let dir = common::image_dir(&format!("bundled_{name}_{method:?}"));
        let exr = dir.join("actual.exr");
        ispm::output::write_exr(&exr, frame.width, frame.height, &frame.hdr).expect("exr");
        let (w, h, pixels) = ispm::output::read_exr(&exr).expect("read exr");
        assert_eq!((w, h), (SIZE, SIZE));
        let bad = pixels
            .iter()
            .filter(|v| !v.is_finite() || **v < 0.0)
            .count();
        assert_eq!(
            bad,
            0,
            "{name}: {bad} NaN/Inf/negative values in {}",
            exr.display()
        );
        let lit = pixels
            .chunks_exact(4)
            .filter(|p| p[0] + p[1] + p[2] > 1e-3)
            .count();
        assert!(
            lit > (SIZE * SIZE / 10) as usize,
            "{name}: only {lit} lit pixels in {}",
            exr.display()
        );
    }
}

/// A sun over a floor 80 m wide, a 0.5 m block on it, and an eye about 2 m away: the block's
/// shadow on the floor is the analytic one everywhere more than two pixels from its edge. One
/// shadow view around the whole scene put 22 cm in a texel here (about ten pixels: the edge a
/// staircase); the view fitted to what the eye sees (`plan/lighting.rs`, "Directional lights")
/// puts under a centimetre.
#[test]
fn a_suns_shadow_on_a_wide_floor_is_the_analytic_one_beyond_two_pixels_of_its_edge() {
    use common::hard::{load_glb, render_hard, settings_for};
    use glam::Quat;
    use ispm::scene::authoring::{cuboid, quad, GltfWriter, MaterialSpec};

    let case = "a_suns_shadow_on_a_wide_floor_is_the_analytic_one_beyond_two_pixels_of_its_edge";
    let sun = Vec3::new(0.5, -1.0, 0.3).normalize();
    let (half, rho, irradiance) = (0.25f32, 0.75f32, 2.0f32);
    let mut w = GltfWriter::default();
    let white = w.material(&MaterialSpec::diffuse("white", [rho; 3]));
    let floor = w.mesh("floor", &quad(Vec3::ZERO, Vec3::Y, 40.0, 40.0), white);
    w.mesh_node("floor", floor, Vec3::ZERO, Quat::IDENTITY);
    let block = w.mesh("block", &cuboid(Vec3::splat(half)), white);
    w.mesh_node("block", block, Vec3::new(0.0, half, 0.0), Quat::IDENTITY);
    w.sun("sun", sun, [1.0; 3], irradiance);
    w.camera(
        "camera",
        Vec3::new(1.2, 1.8, 1.8),
        Vec3::new(0.3, 0.0, 0.3),
        0.8,
    );
    let scene = load_glb("sun_shadow", &w.glb());
    let settings = RenderSettings {
        width: SIZE,
        height: SIZE,
        shadow_resolution: 512,
        ..settings_for(0)
    };
    // No photons: the frame is the direct light alone.
    let hard = render_hard(case, &scene, settings);
    let lit_radiance = rho / std::f32::consts::PI * irradiance * (-sun.y);
    // Shadowed when the ray from p towards the sun crosses the block (slab test).
    let (lo, hi) = (
        Vec3::new(-half, 0.0, -half),
        Vec3::new(half, 2.0 * half, half),
    );
    let in_shadow = |p: Vec3| {
        let towards = -sun;
        let (a, b) = ((lo - p) / towards, (hi - p) / towards);
        let (near, far) = (a.min(b).max_element(), a.max(b).min_element());
        near <= far && far > 0.0
    };
    let n = SIZE as usize;
    let floor_at = |x: usize, y: usize| hard.positions[y * n + x].filter(|p| p.y.abs() < 1e-3);
    let (mut interior, mut wrong) = (0usize, Vec::new());
    let mut expected = vec![0u8; n * n * 4];
    for y in 0..n {
        for x in 0..n {
            let Some(p) = floor_at(x, y) else {
                continue;
            };
            let shadowed = in_shadow(p);
            let v = if shadowed { 0 } else { 255 };
            expected[(y * n + x) * 4..][..4].copy_from_slice(&[v, v, v, 255]);
            // Interior: every pixel within two is floor on the same side of the edge.
            let same = |dx: isize, dy: isize| {
                let (u, w) = (x as isize + dx, y as isize + dy);
                (0..n as isize).contains(&u)
                    && (0..n as isize).contains(&w)
                    && floor_at(u as usize, w as usize).is_some_and(|q| in_shadow(q) == shadowed)
            };
            if !(-2..=2).all(|dy| (-2..=2).all(|dx| same(dx, dy))) {
                continue;
            }
            interior += 1;
            let i = (y * n + x) * 4;
            let luminance = hard.frame.hdr[i..i + 3].iter().sum::<f32>() / 3.0;
            if (luminance / lit_radiance > 0.5) == shadowed {
                wrong.push((x, y));
            }
        }
    }
    let shadowed_pixels = expected
        .chunks(4)
        .filter(|c| c[3] == 255 && c[0] == 0)
        .count();
    eprintln!(
        "{case}: {} of {interior} floor pixels away from the edge on the wrong side \
         ({shadowed_pixels} in the analytic shadow)",
        wrong.len()
    );
    if !wrong.is_empty() {
        let actual = save(case, &hard.frame);
        let dir = common::image_dir(case);
        let mut diff = expected.clone();
        for &(x, y) in &wrong {
            diff[(y * n + x) * 4..][..4].copy_from_slice(&[255, 0, 0, 255]);
        }
        ispm::output::write_png(&dir.join("expected.png"), SIZE, SIZE, &expected).expect("png");
        ispm::output::write_png(&dir.join("difference.png"), SIZE, SIZE, &diff).expect("png");
        panic!(
            "{} pixels on the wrong side of the shadow's edge (red in {}), actual {}",
            wrong.len(),
            dir.join("difference.png").display(),
            actual.display()
        );
    }
    assert!(
        interior > n * n / 3 && shadowed_pixels > 200,
        "the shadow is not in view"
    );
}
