//! Hard cases, geometry (issue #8): degenerate and sliver triangles, coplanar surfaces, thin
//! walls, closed glass, broken normals and a million triangles, each rendered end to end with
//! ISPM on lavapipe with validation on (`common::hard`), each with the assertion that fits it.

mod common;

use common::hard::{self, add_mesh, camera_looking, load_glb, mesh_of, render_hard, stage};
use glam::{Mat4, Quat, Vec2, Vec3};
use ispm::photon::types::unpack_direction;
use ispm::reference::scenes::{closed_box, point_light};
use ispm::scene::authoring::{cuboid, quad, Geometry, GltfWriter, MaterialSpec};
use ispm::scene::{Material, Mesh};

/// The stage under the overhead spot, with `extra` adding objects.
fn lit_stage(extra: impl FnOnce(&mut GltfWriter, usize)) -> Vec<u8> {
    let mut w = GltfWriter::default();
    let floor = stage(&mut w);
    hard::overhead_spot(&mut w);
    extra(&mut w, floor);
    w.glb()
}

/// Zero-area triangles (a repeated vertex, three collinear vertices) and slivers 10 µm wide and
/// 1 m long standing on the floor.
fn degenerate_and_slivers() -> Geometry {
    let mut g = Geometry::default();
    let mut push = |p: [Vec3; 3], n: Vec3| {
        let base = g.positions.len() as u32;
        g.positions.extend(p);
        g.normals.extend([n; 3]);
        g.uvs.extend([Vec2::ZERO; 3]);
        g.indices.extend([base, base + 1, base + 2]);
    };
    let a = Vec3::new(0.2, 0.3, 0.1);
    push([a, a, Vec3::new(0.4, 0.3, 0.1)], Vec3::Y);
    push([a, a * 2.0, a * 3.0], Vec3::Y);
    for k in 0..8 {
        let x = -0.6 + 0.15 * k as f32;
        let base = Vec3::new(x, 0.0, -0.3);
        push(
            [
                base,
                base + Vec3::new(1e-5, 0.0, 0.0),
                base + Vec3::new(0.0, 1.0, 0.0),
            ],
            Vec3::Z,
        );
    }
    g
}

#[test]
fn zero_area_and_sliver_triangles() {
    let bare = load_glb("stage", &lit_stage(|_, _| {}));
    let reference = render_hard(
        "zero_area_and_sliver_triangles",
        &bare,
        hard::settings_for(20_000),
    );
    // Through the loader: the zero-area triangles are dropped, the slivers kept.
    let glb = lit_stage(|w, floor| {
        let m = w.mesh("slivers", &degenerate_and_slivers(), floor);
        w.mesh_node("slivers", m, Vec3::ZERO, Quat::IDENTITY);
    });
    let loaded = load_glb("slivers", &glb);
    let slivers = loaded.meshes.iter().find(|m| m.name.contains("slivers"));
    assert_eq!(slivers.map(|m| m.triangles.len()), Some(8));
    let through_loader = render_hard(
        "zero_area_and_sliver_triangles",
        &loaded,
        hard::settings_for(20_000),
    );
    // Built directly, past the loader: the renderer itself meets the zero-area triangles.
    let mut direct = bare.clone();
    add_mesh(
        &mut direct,
        mesh_of("slivers", &degenerate_and_slivers(), 0),
        Mat4::IDENTITY,
    );
    let past_loader = render_hard(
        "zero_area_and_sliver_triangles",
        &direct,
        hard::settings_for(20_000),
    );
    // Slivers 10 µm wide cover almost no pixel and almost no light-G-buffer texel.
    for frame in [&through_loader, &past_loader] {
        hard::assert_same_image(
            "zero_area_and_sliver_triangles",
            &frame.frame,
            &reference.frame,
            0.03,
        );
    }
}

#[test]
fn coplanar_overlapping_surfaces() {
    // A dark quad lying in the floor's plane (z-fighting), and the same quad 2 cm above it.
    let dark = |lift: f32| {
        lit_stage(move |w, _| {
            let m = w.material(&MaterialSpec::diffuse("dark", [0.2; 3]));
            let mesh = w.mesh("dark", &quad(Vec3::ZERO, Vec3::Y, 0.5, 0.5), m);
            w.mesh_node("dark", mesh, Vec3::new(0.0, lift, 0.0), Quat::IDENTITY);
        })
    };
    let settings = hard::settings_for(20_000);
    let case = "coplanar_overlapping_surfaces";
    let floor_only = render_hard(
        case,
        &load_glb("floor", &lit_stage(|_, _| {})),
        settings.clone(),
    );
    let above = render_hard(case, &load_glb("above", &dark(0.02)), settings.clone());
    let fighting = render_hard(case, &load_glb("coplanar", &dark(0.0)), settings);
    // The quad's pixels (where the lifted quad made the image darker): the coplanar pair shows
    // one surface or the other there, so its mean lies between the two.
    let scene = load_glb("floor", &lit_stage(|_, _| {}));
    let inside = |x: u32, y: u32| {
        let corners = [(-0.4, -0.4), (0.4, 0.4)].map(|(a, b)| {
            scene
                .camera
                .project_to_pixel(Vec3::new(a, 0.0, b), hard::SIZE, hard::SIZE)
                .expect("in view")
        });
        let (lo, hi) = (corners[0].min(corners[1]), corners[0].max(corners[1]));
        (x as f32) > lo.x && (x as f32) < hi.x && (y as f32) > lo.y && (y as f32) < hi.y
    };
    let (bright, dim) = (
        floor_only.mean_where(inside).element_sum(),
        above.mean_where(inside).element_sum(),
    );
    let mixed = fighting.mean_where(inside).element_sum();
    eprintln!("{case}: floor {bright:.4}, dark quad {dim:.4}, coplanar {mixed:.4}");
    assert!(
        dim < 0.6 * bright,
        "the dark quad is not darker: {dim} vs {bright}"
    );
    assert!(
        mixed >= 0.95 * dim && mixed <= 1.05 * bright,
        "coplanar surfaces give {mixed}, outside [{dim}, {bright}]"
    );
}

/// A quad facing `normal` at `center` covering the box's cross-section (half-size 1).
fn divider(normal: Vec3, center: Vec3) -> Mesh {
    mesh_of("divider", &quad(center, normal, 1.0, 1.0), 0)
}

#[test]
fn back_to_back_thin_walls() {
    // The closed box [-1, 1]³ split at x = 0 by two single-sided walls back to back in the
    // same plane; a point light in the left half, the camera in the right half.
    let grey = Material {
        lambertian: Vec3::splat(0.7),
        ..Material::default()
    };
    let mut scene = closed_box(
        std::array::from_fn(|_| grey.clone()),
        point_light(Vec3::new(-0.5, 0.2, 0.1), Vec3::splat(2.0)),
    );
    add_mesh(&mut scene, divider(Vec3::NEG_X, Vec3::ZERO), Mat4::IDENTITY);
    add_mesh(&mut scene, divider(Vec3::X, Vec3::ZERO), Mat4::IDENTITY);
    let case = "back_to_back_thin_walls";
    scene.camera = camera_looking(Vec3::new(-0.95, 0.3, 0.6), Vec3::new(0.0, -0.2, -0.3), 1.4);
    let lit = render_hard(case, &scene, hard::settings_for(20_000));
    scene.camera = camera_looking(Vec3::new(0.95, 0.3, 0.6), Vec3::new(0.0, -0.2, -0.3), 1.4);
    let dark = render_hard(case, &scene, hard::settings_for(20_000));
    // No photon is stored in the right half.
    let leaked = dark.photons.iter().filter(|p| p.position.x > 1e-4).count();
    let lit_mean = lit.mean().element_sum() / 3.0;
    assert!(lit_mean > 0.05, "the lit half is dark: {lit_mean}");
    assert_eq!(leaked, 0, "photons stored behind the wall");
    // A photon's kernel reaches across the wall's zero thickness (photon mapping has no
    // visibility test between photon and shaded point), but the front-side test and the BSDF
    // (zero for light from behind) keep the photons of the wall's lit face off its dark face.
    // So every lit pixel behind the wall lies within one kernel radius of a photon stored on
    // the lit side *off the wall* (on the floor, ceiling or back wall next to it): light that
    // leaked any other way (a photon path through the wall, direct light past the shadow
    // map's bias away from the wall's foot) fails the test.
    let off_wall: Vec<Vec3> = lit_photons(&dark, |p| p.x < -1e-4);
    let (mut reach, mut unexplained) = (0.0f32, 0);
    for (i, p) in dark.positions.iter().enumerate() {
        let Some(p) = p else { continue };
        let radiance = Vec3::from_slice(&dark.frame.hdr[i * 4..i * 4 + 3]).max_element();
        if radiance > 1e-4 * lit_mean {
            reach = reach.max(p.x);
            let nearest = off_wall
                .iter()
                .map(|q| q.distance(*p))
                .fold(f32::INFINITY, f32::min);
            unexplained += usize::from(nearest > dark.r_max);
        }
    }
    eprintln!(
        "{case}: lit half mean {lit_mean:.4}; light reaches {reach:.4} m behind the wall (kernel radius {:.4} m), {unexplained} lit pixels farther than that from every lit-side photon",
        dark.r_max
    );
    if unexplained > 0 {
        hard::save(case, &dark.frame);
        panic!("{unexplained} pixels behind the wall lit by something other than a nearby kernel");
    }
}

/// Positions of the photons of `f` where `keep`.
fn lit_photons(f: &hard::HardFrame, keep: impl Fn(Vec3) -> bool) -> Vec<Vec3> {
    f.photons
        .iter()
        .map(|p| p.position)
        .filter(|p| keep(*p))
        .collect()
}

#[test]
fn closed_glass_mesh() {
    // A closed glass cube (12 triangles, sharp edges) floating above the floor under a sun
    // straight down: light enters and leaves at normal incidence, so the floor below receives
    // E·A·T (T the transmittance through two faces, 0.8…1), in photons arriving vertically.
    let (half, e) = (0.3f32, 2.0f32);
    let mut w = GltfWriter::default();
    stage(&mut w);
    let glass = w.material(&MaterialSpec::glass("glass"));
    let cube = w.mesh("cube", &cuboid(Vec3::splat(half)), glass);
    w.mesh_node("cube", cube, Vec3::new(0.0, 0.6, 0.0), Quat::IDENTITY);
    w.sun("sun", Vec3::NEG_Y, [1.0; 3], e);
    let scene = load_glb("glass-cube", &w.glb());
    let f = render_hard("closed_glass_mesh", &scene, hard::settings_for(20_000));
    let under = |p: Vec3| p.x.abs() < half - 0.01 && p.z.abs() < half - 0.01;
    let inside = f
        .photons
        .iter()
        .filter(|p| under(p.position) && (p.position.y - 0.6).abs() < half - 1e-3)
        .count();
    let caustic: f64 = f
        .photons
        .iter()
        .filter(|p| under(p.position) && p.position.y.abs() < 1e-3)
        .filter(|p| unpack_direction(p.direction).0.y.abs() > 0.9998)
        .map(|p| f64::from(p.power.element_sum() / 3.0))
        .sum();
    let expected = f64::from(e) * f64::from(2.0 * half - 0.02).powi(2);
    let t = caustic / expected;
    eprintln!("closed_glass_mesh: transmitted {caustic:.4} W of {expected:.4} W (T = {t:.3}), {inside} photons inside");
    assert_eq!(inside, 0, "photons stored inside the glass");
    assert!(
        (0.8..=1.0).contains(&t),
        "transmittance {t} through the closed glass cube"
    );
}

/// The stage with a block whose normals are `normals(correct)`.
fn block_with_normals(normals: impl Fn(&[Vec3]) -> Vec<Vec3>) -> Vec<u8> {
    lit_stage(|w, floor| {
        let mut g = cuboid(Vec3::splat(0.3));
        g.normals = normals(&g.normals);
        let m = w.mesh("block", &g, floor);
        w.mesh_node(
            "block",
            m,
            Vec3::new(0.0, 0.3, 0.0),
            Quat::from_rotation_y(0.4),
        );
    })
}

/// Turns a mesh's correct normals into broken ones.
type NormalsEdit = fn(&[Vec3]) -> Vec<Vec3>;

#[test]
fn missing_flipped_and_zero_length_normals() {
    let case = "missing_flipped_and_zero_length_normals";
    let correct = load_glb("correct", &block_with_normals(<[Vec3]>::to_vec));
    let reference = render_hard(case, &correct, hard::settings_for(20_000));
    let block = |s: &ispm::scene::Scene| {
        s.meshes
            .iter()
            .find(|m| m.name.contains("block"))
            .expect("block")
            .clone()
    };
    let variants: [(&str, NormalsEdit); 3] = [
        ("missing", |_| Vec::new()),
        ("zero-length", |n| vec![Vec3::ZERO; n.len()]),
        ("flipped", |n| n.iter().map(|v| -*v).collect()),
    ];
    for (name, normals) in variants {
        let scene = load_glb(name, &block_with_normals(normals));
        // The loader recomputes them from the geometry: the block's faces are flat, so every
        // vertex gets its face's normal back.
        let (got, want) = (block(&scene), block(&correct));
        for t in &got.triangles {
            let [a, b, c] = t.map(|i| got.positions[i as usize]);
            let face = (b - a).cross(c - a).normalize();
            for &i in t {
                let n = got.normals[i as usize];
                assert!(
                    (n - face).length() < 1e-5,
                    "{name}: normal {n} on a face {face}"
                );
            }
        }
        assert_eq!(got.triangles.len(), want.triangles.len(), "{name}");
        let frame = render_hard(case, &scene, hard::settings_for(20_000));
        hard::assert_same_image(case, &frame.frame, &reference.frame, 1e-3);
    }
}

#[test]
fn a_million_tiny_triangles() {
    // The floor as a 708 × 708 grid (1 002 528 triangles) against the same floor of 2: the same
    // image, within the time budget.
    let floor = |cells: u32| {
        let mut g = ispm::photon::shapes::grid(cells, |_, _| 0.0);
        g.material = 0;
        let s = 3.0 / cells as f32;
        (
            g,
            Mat4::from_scale_rotation_translation(
                Vec3::splat(s),
                Quat::IDENTITY,
                Vec3::new(-1.5, 0.0, -1.5),
            ),
        )
    };
    let scene_of = |cells: u32| {
        let mut scene = load_glb("stage", &lit_stage(|_, _| {}));
        scene.instances.clear();
        scene.meshes.clear();
        let (mesh, at) = floor(cells);
        add_mesh(&mut scene, mesh, at);
        scene
    };
    let case = "a_million_tiny_triangles";
    let two = render_hard(case, &scene_of(1), hard::settings_for(20_000));
    let dense = scene_of(708);
    assert!(dense.triangle_count() >= 1_000_000);
    let start = std::time::Instant::now();
    let million = render_hard(case, &dense, hard::settings_for(20_000));
    let seconds = start.elapsed().as_secs_f64();
    eprintln!(
        "{case}: {} triangles rendered in {seconds:.1} s",
        dense.triangle_count()
    );
    hard::assert_same_image(case, &million.frame, &two.frame, 0.02);
    assert!(seconds < 20.0, "{seconds} s for a million triangles");
}
