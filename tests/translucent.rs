//! Glass and mirrors: the environment cube map and the translucent forward pass, on lavapipe
//! with validation on.

mod common;

use glam::{Vec2, Vec3};
use ispm::config::settings::{Method, RenderSettings};
use ispm::render::frame::Renderer;
use ispm::render::stats::FrameImage;
use ispm::scene::{bundled, Scene};

const WIDTH: u32 = 160;
const HEIGHT: u32 = 120;

fn settings(method: Method) -> RenderSettings {
    RenderSettings {
        method,
        photons: 20_000,
        width: WIDTH,
        height: HEIGHT,
        shadow_resolution: 512,
        ..Default::default()
    }
}

/// Renders `frames` frames of `scene` and returns them, checking validation at the end.
fn render(scene: &Scene, method: Method, frames: usize) -> Vec<FrameImage> {
    let gpu = common::gpu();
    let images = {
        let mut r = Renderer::new(&gpu, scene, settings(method)).expect("renderer");
        (0..frames).map(|_| r.render().expect("render")).collect()
    };
    common::assert_validation_clean(&gpu);
    images
}

fn save(test: &str, frame: &FrameImage) -> std::path::PathBuf {
    let png = common::image_dir(test).join("actual.png");
    ispm::output::write_png(&png, frame.width, frame.height, &frame.ldr).expect("png");
    png
}

/// Mean linear RGB over the (2r+1)² block around the pixel where world point `p` lands.
fn radiance_at(scene: &Scene, frame: &FrameImage, p: Vec3, r: i32) -> Vec3 {
    let px: Vec2 = scene
        .camera
        .project_to_pixel(p, frame.width, frame.height)
        .expect("point in front of the camera");
    let (cx, cy) = (px.x as i32, px.y as i32);
    let mut sum = Vec3::ZERO;
    for dy in -r..=r {
        for dx in -r..=r {
            let x = (cx + dx).clamp(0, frame.width as i32 - 1) as usize;
            let y = (cy + dy).clamp(0, frame.height as i32 - 1) as usize;
            let i = (y * frame.width as usize + x) * 4;
            sum += Vec3::new(frame.hdr[i], frame.hdr[i + 1], frame.hdr[i + 2]);
        }
    }
    sum / ((2 * r + 1) * (2 * r + 1)) as f32
}

fn assert_finite_and_non_negative(frame: &FrameImage, what: &str) {
    let bad = frame
        .hdr
        .iter()
        .filter(|v| !v.is_finite() || **v < 0.0)
        .count();
    assert_eq!(
        bad, 0,
        "{what}: {bad} NaN, infinite or negative radiance values"
    );
}

fn ran(frame: &FrameImage, pass: &str) -> bool {
    frame.stats.passes_run.iter().any(|p| p == pass)
}

#[test]
fn glass_sphere_shows_its_surroundings_instead_of_black() {
    let scene = bundled::resolve(Some("glass-sphere")).expect("bundled scene");
    for method in [Method::Ispm, Method::Direct] {
        let frames = render(&scene, method, 1);
        let frame = &frames[0];
        let path = save(&format!("glass_sphere_{method:?}"), frame);
        assert_finite_and_non_negative(frame, "glass-sphere");
        assert!(
            ran(frame, "environment") && ran(frame, "translucent"),
            "passes run: {:?}",
            frame.stats.passes_run
        );
        // The ball is convex: nothing is drawn without the shortcut.
        assert!(
            (frame.stats.variants_skipped.iter()).all(|v| v.name != "convex_shortcut"),
            "{:?}",
            frame.stats.variants_skipped
        );
        let glass = radiance_at(&scene, frame, Vec3::new(0.0, 0.5, 0.0), 6);
        let floor = radiance_at(&scene, frame, Vec3::new(0.0, 0.0, 0.9), 2);
        assert!(
            floor.length() > 0.05,
            "lit floor {floor} ({})",
            path.display()
        );
        assert!(
            glass.length() > 0.1 * floor.length(),
            "{method:?}: glass sphere {glass} vs lit floor {floor} ({})",
            path.display()
        );
    }
}

#[test]
fn caustic_ring_mirror_reflects_the_floor() {
    let scene = bundled::resolve(Some("caustic-ring")).expect("bundled scene");
    let frames = render(&scene, Method::Ispm, 1);
    let frame = &frames[0];
    let path = save("caustic_ring_mirror", frame);
    assert_finite_and_non_negative(frame, "caustic-ring");
    assert!(ran(frame, "translucent"), "{:?}", frame.stats.passes_run);
    // The ring (radius 0.5, 0.2 high, at the origin) halfway up its wall, all the way round.
    let steps = 24;
    let ring: Vec3 = (0..steps)
        .map(|i| {
            let a = i as f32 / steps as f32 * std::f32::consts::TAU;
            radiance_at(
                &scene,
                frame,
                Vec3::new(0.5 * a.cos(), 0.1, 0.5 * a.sin()),
                0,
            )
        })
        .sum::<Vec3>()
        / steps as f32;
    let floor = radiance_at(&scene, frame, Vec3::new(0.9, 0.0, 0.6), 2);
    assert!(
        ring.length() > 0.1 * floor.length(),
        "mirror ring {ring} vs floor {floor} ({})",
        path.display()
    );
}

/// A glass cube (0.6 m, η = 1.5) floating 0.3 m over a floor whose colour changes from red to
/// green at x = 0.275, seen from 30 m straight above: an eye ray through the top face crosses
/// two parallel faces at near-normal incidence and lands a few millimetres from below where it
/// entered, so the top face shows the floor under it: red near its corners on the red side and
/// 0.25 m off the centre, green beside the cube. (Leaving the cube through its bounding sphere,
/// as the pass did before it traced the cube's own triangles, bent the rays near the corners
/// by tens of degrees: the corners showed black or the far green floor; checked.) The floor
/// under the cube is in its shadow: the refracted sun's caustic photons light it.
#[test]
fn a_glass_cube_shows_the_floor_straight_through_its_far_face() {
    use ispm::scene::authoring::{cuboid, quad, GltfWriter, MaterialSpec};
    let edge = 0.275;
    let mut w = GltfWriter::default();
    let red = w.material(&MaterialSpec::diffuse("red", [0.8, 0.1, 0.1]));
    let green = w.material(&MaterialSpec::diffuse("green", [0.1, 0.8, 0.1]));
    // quad's half-sizes: along z, then along x.
    let left = w.mesh(
        "floor-red",
        &quad(
            Vec3::new((edge - 2.0) / 2.0, 0.0, 0.0),
            Vec3::Y,
            2.0,
            (edge + 2.0) / 2.0,
        ),
        red,
    );
    let right = w.mesh(
        "floor-green",
        &quad(
            Vec3::new((edge + 2.0) / 2.0, 0.0, 0.0),
            Vec3::Y,
            2.0,
            (2.0 - edge) / 2.0,
        ),
        green,
    );
    w.mesh_node("floor-red", left, Vec3::ZERO, glam::Quat::IDENTITY);
    w.mesh_node("floor-green", right, Vec3::ZERO, glam::Quat::IDENTITY);
    let glass = w.material(&MaterialSpec::glass("glass"));
    let cube = w.mesh("cube", &cuboid(Vec3::splat(0.3)), glass);
    w.mesh_node("cube", cube, Vec3::new(0.0, 0.6, 0.0), glam::Quat::IDENTITY);
    w.sun("sun", Vec3::NEG_Y, [1.0; 3], 3.0);
    // A pixel is 10 mm on the cube's top face.
    w.camera("camera", Vec3::new(0.0, 30.0, 0.1), Vec3::ZERO, 0.04);
    let scene = common::hard::load_glb("glass-cube-over-two-colours", &w.glb());
    let frames = render(&scene, Method::Ispm, 1);
    let frame = &frames[0];
    let path = save("glass_cube_far_face", frame);
    assert_finite_and_non_negative(frame, "glass cube");
    let points = [
        (Vec3::new(0.25, 0.9, 0.0), true),
        (Vec3::new(-0.27, 0.9, -0.27), true),
        (Vec3::new(-0.27, 0.9, 0.27), true),
        (Vec3::new(0.45, 0.0, 0.0), false),
    ];
    for (p, red_side) in points {
        let c = radiance_at(&scene, frame, p, 0);
        assert!(
            c.max_element() > 0.02,
            "{p}: {c} is dark ({})",
            path.display()
        );
        assert!(
            (c.x > 2.0 * c.y) == red_side && (c.y > 2.0 * c.x) != red_side,
            "{p}: {c} should show the {} floor ({})",
            if red_side { "red" } else { "green" },
            path.display()
        );
    }
}

/// Two mirrors 1.2 m apart facing each other across a red block on a green floor, the left one
/// moved `left_offset` along x from its place (x = -0.6), seen from where the left mirror's low
/// part reflects the floor beside the block.
fn mirrors_across_a_red_block(left_offset: f32) -> Scene {
    use ispm::scene::authoring::{cuboid, quad, GltfWriter, MaterialSpec};
    let mut w = GltfWriter::default();
    let green = w.material(&MaterialSpec::diffuse("green", [0.1, 0.8, 0.1]));
    let red = w.material(&MaterialSpec::diffuse("red", [0.8, 0.1, 0.1]));
    let mirror = w.material(&MaterialSpec::mirror("mirror", [0.95; 3]));
    let floor = w.mesh("floor", &quad(Vec3::ZERO, Vec3::Y, 2.0, 2.0), green);
    w.mesh_node("floor", floor, Vec3::ZERO, glam::Quat::IDENTITY);
    let block = w.mesh("block", &cuboid(Vec3::splat(0.25)), red);
    w.mesh_node(
        "block",
        block,
        Vec3::new(0.0, 0.25, 0.0),
        glam::Quat::IDENTITY,
    );
    for (name, x, n, offset) in [
        ("left", -0.6, Vec3::X, left_offset),
        ("right", 0.6, Vec3::NEG_X, 0.0),
    ] {
        let mesh = w.mesh(name, &quad(Vec3::new(x, 0.6, 0.0), n, 0.8, 0.6), mirror);
        w.mesh_node(name, mesh, Vec3::X * offset, glam::Quat::IDENTITY);
    }
    w.sun("sun", Vec3::NEG_Y, [1.0; 3], 3.0);
    w.camera(
        "camera",
        Vec3::new(0.4, 0.9, 1.8),
        Vec3::new(-0.6, 0.2, 0.3),
        0.9,
    );
    common::hard::load_glb("mirrors-across-a-red-block", &w.glb())
}

/// The colour the left mirror of [`mirrors_across_a_red_block`] shows, low: its reflection meets
/// the floor at about (-0.39, 0, 0), 0.14 m beside the block. Green seen from the mirror, red
/// seen from a point the block stands in front of.
fn left_mirror_low(scene: &Scene, frame: &FrameImage) -> Vec3 {
    radiance_at(scene, frame, Vec3::new(-0.6, 0.15, 0.3), 1)
}

/// Fails unless `c` is the green floor of these tests as a mirror shows it: green at least twice
/// red, and lit. `what` names the mirror; `image` is the saved frame.
fn assert_shows_green(c: Vec3, what: &str, image: &std::path::Path) {
    assert!(
        c.y > 2.0 * c.x && c.y > 0.05,
        "{what} shows {c} where the green floor is ({})",
        image.display()
    );
}

/// Each mirror is a probe of its own, so the floor beside the left mirror, reflected low in it,
/// is looked up from the mirror and shows green. With one probe for both (centred between the
/// mirrors, just above the block, as before each delta instance had its own) the same floor
/// point is seen from above the block and the mirror showed red (checked with `MAX_PROBES` = 1).
#[test]
fn each_mirror_sees_the_floor_from_where_it_stands() {
    let scene = mirrors_across_a_red_block(0.0);
    let frames = render(&scene, Method::Ispm, 1);
    let frame = &frames[0];
    let path = save("each_mirror_sees_the_floor", frame);
    assert_finite_and_non_negative(frame, "two mirrors");
    assert_shows_green(left_mirror_low(&scene, frame), "the left mirror", &path);
}

/// The left mirror starts 3.6 m to the right of its place and moves there: its probe follows it
/// (`TranslucentFrame::moved`), so the mirror shows the green floor beside it. With the probe
/// left where the mirror started, at x = 3, the mirror showed (0.012, 0.012, 0.001), not the
/// floor (checked by leaving the centres as they were).
#[test]
fn a_moved_mirror_takes_its_probe_along() {
    let scene = mirrors_across_a_red_block(3.6);
    let gpu = common::gpu();
    let mut renderer = Renderer::new(&gpu, &scene, settings(Method::Ispm)).expect("renderer");
    renderer.render().expect("first frame");
    let left = scene.instances.iter().position(|i| i.name == "left");
    let mut transforms = renderer.instance_transforms();
    transforms[left.expect("left mirror")] = glam::Mat4::IDENTITY;
    renderer.set_instance_transforms(&transforms).expect("move");
    let frame = renderer.render().expect("frame after the move");
    common::assert_validation_clean(&gpu);
    let path = save("moved_mirror", &frame);
    assert_finite_and_non_negative(&frame, "moved mirror");
    assert_shows_green(
        left_mirror_low(&scene, &frame),
        "the moved left mirror",
        &path,
    );
}

/// Five mirrors in a row, one more than there are probes: the fourth and fifth share the last
/// probe (`plan::probes::MAX_PROBES`), and every mirror still shows the green floor in front of
/// it, each draw with its probe's set (validation on). A mirror not drawn would show the red
/// floor behind it (checked by skipping the last probe's draws).
#[test]
fn more_mirrors_than_probes_share_the_last_and_all_show_the_floor() {
    use ispm::plan::probes::MAX_PROBES;
    use ispm::scene::authoring::{quad, GltfWriter, MaterialSpec};
    let mut w = GltfWriter::default();
    let green = w.material(&MaterialSpec::diffuse("green", [0.1, 0.8, 0.1]));
    let red = w.material(&MaterialSpec::diffuse("red", [0.8, 0.1, 0.1]));
    let mirror = w.material(&MaterialSpec::mirror("mirror", [0.95; 3]));
    // Green in front of the mirrors (z > 0), red behind them: a mirror left undrawn shows red.
    // quad's half-sizes: along z, then along x.
    for (name, z, material) in [("front", 1.5, green), ("back", -1.5, red)] {
        let floor = w.mesh(
            name,
            &quad(Vec3::new(0.0, 0.0, z), Vec3::Y, 1.5, 3.0),
            material,
        );
        w.mesh_node(name, floor, Vec3::ZERO, glam::Quat::IDENTITY);
    }
    let xs = [-1.0, -0.5, 0.0, 0.5, 1.0];
    assert!(xs.len() > MAX_PROBES);
    let mesh = w.mesh(
        "mirror",
        &quad(Vec3::new(0.0, 0.2, 0.0), Vec3::Z, 0.15, 0.2),
        mirror,
    );
    for (i, x) in xs.iter().enumerate() {
        w.mesh_node(
            &format!("mirror-{i}"),
            mesh,
            Vec3::new(*x, 0.0, 0.0),
            glam::Quat::IDENTITY,
        );
    }
    w.sun("sun", Vec3::NEG_Y, [1.0; 3], 3.0);
    w.camera(
        "camera",
        Vec3::new(0.0, 1.5, 2.5),
        Vec3::new(0.0, 0.1, 0.0),
        0.9,
    );
    let scene = common::hard::load_glb("five-mirrors", &w.glb());
    let frames = render(&scene, Method::Ispm, 1);
    let frame = &frames[0];
    let path = save("five_mirrors", frame);
    assert_finite_and_non_negative(frame, "five mirrors");
    for x in xs {
        // Each mirror reflects the eye's downward ray onto the floor in front of it.
        let c = radiance_at(&scene, frame, Vec3::new(x, 0.12, 0.0), 0);
        assert_shows_green(c, &format!("the mirror at x = {x}"), &path);
    }
}

#[test]
fn environment_map_is_rendered_once_and_reused() {
    let scene = bundled::resolve(Some("caustic-ring")).expect("bundled scene");
    let frames = render(&scene, Method::Direct, 2);
    assert!(ran(&frames[0], "environment"), "{:?}", frames[0].stats);
    assert!(
        !ran(&frames[1], "environment") && ran(&frames[1], "translucent"),
        "second frame: {:?}",
        frames[1].stats.passes_run
    );
    assert_eq!(
        frames[0].hdr, frames[1].hdr,
        "the cached cube map renders the same frame"
    );
}

#[test]
fn scene_without_delta_materials_runs_no_translucent_pass() {
    let scene = ispm::reference::scenes::grey_box(0.5, 1.0);
    for method in [Method::Ispm, Method::Direct] {
        let frames = render(&scene, method, 1);
        let frame = &frames[0];
        assert_finite_and_non_negative(frame, "grey box");
        assert!(
            !ran(frame, "translucent") && !ran(frame, "environment"),
            "{method:?}: passes run: {:?}",
            frame.stats.passes_run
        );
        assert!(ran(frame, "direct"), "{:?}", frame.stats.passes_run);
    }
}

/// Rays leaving a convex glass through the plane of their face skip the traversal of its own
/// triangles (`passes/translucent/object_bvh.rs`, "Convex meshes"), and no pixel changes for
/// it. glass-sphere's ball, placed mirrored and stretched (a model matrix of negative
/// determinant and unequal scales), is rendered as it is and with a speck inside it: a triangle
/// 10⁻⁵ m wide at its centre, which no ray meets but which makes the mesh not convex, so that
/// every ray is traversed. A second, specked ball beside it in both makes the pass draw the
/// first with the convex pipeline and the second with the plain one in the same frame
/// (`passes/translucent.rs`; both on screen from outside). The camera outside, then inside the
/// first ball.
#[test]
fn skipping_the_traversal_for_rays_leaving_convex_glass_changes_no_pixel() {
    use ispm::passes::translucent::object_bvh::convex_centre;
    let mut scene = bundled::resolve(Some("glass-sphere")).expect("bundled scene");
    let delta: Vec<usize> = (0..scene.instances.len())
        .filter(|&i| {
            let mesh = &scene.meshes[scene.instances[i].mesh];
            scene.materials[mesh.material].has_delta_lobe()
        })
        .collect();
    assert!(!delta.is_empty());
    for &i in &delta {
        scene.instances[i].transform *= glam::Mat4::from_scale(Vec3::new(-1.0, 0.8, 1.2));
    }
    let mut specked = scene.clone();
    for &i in &delta {
        let mesh = &mut specked.meshes[scene.instances[i].mesh];
        assert!(convex_centre(mesh).is_some(), "{} is convex", mesh.name);
        let centre = mesh.positions.iter().copied().sum::<Vec3>() / mesh.positions.len() as f32;
        let n = mesh.positions.len() as u32;
        for corner in [Vec3::ZERO, Vec3::X, Vec3::Z] {
            mesh.positions.push(centre + corner * 1e-5);
            mesh.normals.push(Vec3::Y);
            mesh.uvs.push(Vec2::ZERO);
        }
        mesh.triangles.push([n, n + 1, n + 2]);
        assert!(
            convex_centre(mesh).is_none(),
            "the speck makes {} not convex",
            mesh.name
        );
    }
    let (ball, radius) = {
        let inst = &scene.instances[delta[0]];
        let mesh = &scene.meshes[inst.mesh];
        let centre = mesh.positions.iter().copied().sum::<Vec3>() / mesh.positions.len() as f32;
        let world = |p: Vec3| inst.transform.transform_point3(p);
        let radius = (mesh.positions.iter())
            .map(|&p| world(p).distance(world(centre)))
            .fold(0.0, f32::max);
        (world(centre), radius)
    };
    // The second ball: the first's specked mesh, its centre 1.1 diameters to the camera's
    // right.
    let beside = glam::Mat4::from_translation(
        scene.camera.transform.x_axis.truncate().normalize() * 2.2 * radius,
    );
    let first = scene.instances[delta[0]].clone();
    let mut mesh = specked.meshes[first.mesh].clone();
    mesh.name = format!("{} beside", mesh.name);
    for s in [&mut scene, &mut specked] {
        s.meshes.push(mesh.clone());
        s.instances.push(ispm::scene::Instance {
            name: format!("{} beside", first.name),
            mesh: s.meshes.len() - 1,
            transform: beside * first.transform,
        });
    }
    for inside in [false, true] {
        let (mut a, mut b) = (scene.clone(), specked.clone());
        if inside {
            for s in [&mut a, &mut b] {
                s.camera.transform.w_axis = (ball + Vec3::new(0.01, 0.02, 0.03)).extend(1.0);
            }
        }
        let (fa, fb) = (
            &render(&a, Method::Direct, 1)[0],
            &render(&b, Method::Direct, 1)[0],
        );
        if !inside {
            let on_screen = |p: Vec3| {
                a.camera
                    .project_to_pixel(p, fa.width, fa.height)
                    .is_some_and(|px| {
                        (0.0..fa.width as f32).contains(&px.x)
                            && (0.0..fa.height as f32).contains(&px.y)
                    })
            };
            assert!(
                on_screen(ball) && on_screen(beside.transform_point3(ball)),
                "both balls' centres on screen"
            );
        }
        assert!(ran(fa, "translucent") && ran(fb, "translucent"));
        // The stats name the meshes drawn without the shortcut: the specked ones.
        let not_convex = |f: &FrameImage| {
            (f.stats.variants_skipped.iter())
                .find(|v| v.name == "convex_shortcut")
                .map(|v| v.reason.clone())
                .unwrap_or_default()
        };
        let listed = |f: &FrameImage, m: usize| {
            let name = &a.meshes[m].name;
            not_convex(f).contains(&format!("'{name}' (mesh {m})"))
        };
        let beside_mesh = a.meshes.len() - 1;
        assert!(
            listed(fa, beside_mesh) && !listed(fa, first.mesh),
            "{}",
            not_convex(fa)
        );
        assert!(
            listed(fb, beside_mesh) && listed(fb, first.mesh),
            "{}",
            not_convex(fb)
        );
        let worst = fa
            .hdr
            .iter()
            .zip(&fb.hdr)
            .map(|(x, y)| (x - y).abs() / (x.abs() + 1e-2))
            .fold(0.0, f32::max);
        assert!(
            worst < 1e-4,
            "camera inside: {inside}: relative difference {worst} ({}, {})",
            save(&format!("convex_shortcut_{inside}_skipped"), fa).display(),
            save(&format!("convex_shortcut_{inside}_traversed"), fb).display()
        );
    }
}
