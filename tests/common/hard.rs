//! What the hard-case tests (docs/stability.md) share: a small lit box authored at any scale
//! and place, a frame rendered with the GPU value check on, and the assertions every case
//! makes (no bad value in any buffer, a finite non-negative EXR, validation silent).
//!
//! ## The catalogue (geometry, lights, materials, budgets)
//!
//! [`render_hard`] renders one frame with `--method ispm` and fails the test when
//!
//! - validation or synchronization validation reported anything;
//! - the GPU value check (`RenderSettings::check_values`, `passes/value_check.rs`) counted a
//!   NaN, ±Inf or negative value in any buffer it reads (direct, bounce map, photon map,
//!   indirect, final HDR);
//! - the linear HDR frame holds a NaN, an infinity or a negative value;
//! - a photon of the photon map or a record of the bounce map holds one (power, direction,
//!   position, normal; bounce-map depth and η), or a negative power.
//!
//! On failure the HDR frame is written to `target/tmp/test-images/<case>/actual.exr` (and a PNG
//! beside it) before the panic. Scenes are generated in the tests with
//! `ispm::scene::authoring` (see [`load_glb`]) or built directly as a [`Scene`].

use glam::{Mat4, Quat, Vec3};
use ispm::config::settings::{Method, RenderSettings};
use ispm::gpu::Gpu;
use ispm::photon::types::{BounceMapPhoton, Photon};
use ispm::render::frame::Renderer;
use ispm::render::stats::FrameImage;
use ispm::scene::authoring::{
    cornell_room, cuboid, icosphere, quad, Geometry, GltfWriter, MaterialSpec,
};
use ispm::scene::{Camera, Instance, Mesh, Scene};

/// Spot intensity of the unit-scale box, W/sr.
pub const SPOT_W_PER_SR: f32 = 4.0;

/// A 2 m box (white floor, ceiling and back wall, red left and green right wall, open towards
/// the camera at +Z) with a white block, lit by one spot under the ceiling aiming down, seen
/// from the open side: every length multiplied by `scale`, then moved by `offset`. The spot's
/// intensity is multiplied by `scale²`, so the irradiance at every scaled point, and therefore
/// the radiance of the image, is the same at every scale (the camera's near plane follows the
/// scale too, as a file authored at that scale would have it).
pub fn lit_box(scale: f32, offset: Vec3) -> Scene {
    lit_box_with(scale, offset, false)
}

/// [`lit_box`], with a glass ball (η = 1.5, radius 0.25 m before scaling) on the floor in
/// front of the block when `glass`: the translucent pass and caustic views at that scale.
pub fn lit_box_with(scale: f32, offset: Vec3, glass: bool) -> Scene {
    let mut w = GltfWriter::default();
    let at = |p: Vec3| offset + p * scale;
    let white = cornell_room(&mut w, scale, offset);
    let block = w.mesh("block", &cuboid(Vec3::new(0.3, 0.6, 0.3) * scale), white);
    w.mesh_node(
        "block",
        block,
        at(Vec3::new(-0.35, 0.6, -0.3)),
        Quat::from_rotation_y(0.3),
    );
    if glass {
        let material = w.material(&MaterialSpec::glass("glass"));
        let ball = w.mesh("glass-ball", &icosphere(0.25 * scale, 2), material);
        w.mesh_node(
            "glass-ball",
            ball,
            at(Vec3::new(0.4, 0.25, 0.2)),
            Quat::IDENTITY,
        );
    }
    let spot = Vec3::new(0.0, 1.95, 0.0);
    w.spot(
        "spot",
        at(spot),
        at(spot - Vec3::Y),
        [1.0, 1.0, 1.0],
        SPOT_W_PER_SR * scale * scale,
        (0.7, 0.9),
    );
    w.camera(
        "camera",
        at(Vec3::new(0.0, 1.0, 3.6)),
        at(Vec3::new(0.0, 1.0, 0.0)),
        0.7,
    );
    load(w, scale)
}

/// Two rooms of [`lit_box`] side by side, 0.5 m apart (the first centred on x = −1.25, the
/// second on x = +1.25), each lit by its own spot under the ceiling, both open towards the
/// camera, which sees both: no light of one room can reach the other (nothing outside them
/// sends it back in). Light 0 lights the first room, light 1 the second.
pub fn two_rooms() -> Scene {
    let mut w = GltfWriter::default();
    for (x, name) in [(-1.25f32, "spot-left"), (1.25, "spot-right")] {
        let white = cornell_room(&mut w, 1.0, Vec3::new(x, 0.0, 0.0));
        let block = w.mesh("block", &cuboid(Vec3::new(0.3, 0.6, 0.3)), white);
        w.mesh_node(
            "block",
            block,
            Vec3::new(x - 0.35, 0.6, -0.3),
            Quat::from_rotation_y(0.3),
        );
        let spot = Vec3::new(x, 1.95, 0.0);
        w.spot(
            name,
            spot,
            spot - Vec3::Y,
            [1.0; 3],
            SPOT_W_PER_SR,
            (0.7, 0.9),
        );
    }
    w.camera(
        "camera",
        Vec3::new(0.0, 1.0, 6.5),
        Vec3::new(0.0, 1.0, 0.0),
        0.7,
    );
    load(w, 1.0)
}

/// The scene `w` wrote, its cameras' near and far planes scaled by `scale`.
fn load(w: GltfWriter, scale: f32) -> Scene {
    let mut scene = ispm::scene::load::load_from_slice(&w.glb(), "hard-case.glb", None)
        .expect("the authored scene loads");
    for camera in std::iter::once(&mut scene.camera).chain(&mut scene.cameras) {
        camera.znear *= scale;
        camera.zfar = camera.zfar.map(|f| f * scale);
    }
    scene
}

/// Small, fast settings with the value check on.
pub fn settings(width: u32, height: u32) -> RenderSettings {
    RenderSettings {
        photons: 20_000,
        width,
        height,
        shadow_resolution: 256,
        check_values: true,
        ..Default::default()
    }
}

/// A rendered frame and its indirect image (RGBA f32; empty without indirect light).
pub struct Checked {
    pub frame: FrameImage,
    pub indirect: Vec<f32>,
}

impl Checked {
    /// The direct part: final − indirect (scenes without glass or mirrors).
    pub fn direct(&self) -> Vec<f32> {
        if self.indirect.is_empty() {
            return self.frame.hdr.clone();
        }
        self.frame
            .hdr
            .iter()
            .zip(&self.indirect)
            .map(|(f, i)| f - i)
            .collect()
    }
}

/// Renders one frame of `scene` and asserts what every hard case asserts: the GPU found no
/// NaN, ±Inf or negative value in any buffer, and the EXR written from the frame reads back
/// finite and non-negative. `name` names the EXR under `target/tmp/test-images/`.
pub fn render_checked(
    gpu: &std::sync::Arc<Gpu>,
    scene: &Scene,
    settings: RenderSettings,
    name: &str,
) -> Checked {
    let mut renderer = Renderer::new(gpu, scene, settings).expect("renderer");
    let frame = renderer.render().expect("render");
    let indirect = renderer
        .photons()
        .map(|p| p.read_indirect().expect("indirect"))
        .unwrap_or_default();
    assert_frame_clean(&frame, name);
    Checked { frame, indirect }
}

/// The GPU's value check found nothing and the frame's EXR is finite and non-negative.
pub fn assert_frame_clean(frame: &FrameImage, name: &str) {
    let check = frame
        .stats
        .value_check
        .as_ref()
        .expect("rendered with check_values");
    assert_eq!(check.total_bad(), 0, "{name}: {check:?}");
    let path = super::image_dir("hard").join(format!("{name}.exr"));
    ispm::output::write_exr(&path, frame.width, frame.height, &frame.hdr).expect("write EXR");
    let (w, h, pixels) = ispm::output::read_exr(&path).expect("read EXR");
    assert_eq!((w, h), (frame.width, frame.height));
    assert!(
        pixels.iter().all(|v| v.is_finite() && *v >= 0.0),
        "{name}: the EXR holds a non-finite or negative value"
    );
}

/// Σ|a − b| ÷ Σ|b| over the RGB channels of two RGBA images.
pub fn relative_l1(a: &[f32], b: &[f32]) -> f64 {
    assert_eq!(a.len(), b.len());
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for (pa, pb) in a.chunks_exact(4).zip(b.chunks_exact(4)) {
        for c in 0..3 {
            num += f64::from((pa[c] - pb[c]).abs());
            den += f64::from(pb[c].abs());
        }
    }
    num / den.max(1e-30)
}

/// The mean of the RGB channels of an RGBA image.
pub fn mean(image: &[f32]) -> f64 {
    let (sum, n) = image.chunks_exact(4).fold((0.0f64, 0usize), |(s, n), p| {
        (s + f64::from(p[0] + p[1] + p[2]), n + 3)
    });
    sum / n.max(1) as f64
}

/// `image` (RGBA, `width` wide) averaged over `block`×`block` tiles: RGBA again.
pub fn block_average(image: &[f32], width: u32, block: u32) -> Vec<f32> {
    let height = image.len() as u32 / 4 / width;
    let (bw, bh) = (width / block, height / block);
    let mut out = vec![0.0f32; (bw * bh * 4) as usize];
    for y in 0..bh * block {
        for x in 0..bw * block {
            let src = ((y * width + x) * 4) as usize;
            let dst = (((y / block) * bw + x / block) * 4) as usize;
            for c in 0..4 {
                out[dst + c] += image[src + c] / (block * block) as f32;
            }
        }
    }
    out
}

/// Image side of the hard cases (64×64: each file stays well under a minute on lavapipe).
pub const SIZE: u32 = 64;

/// What a hard case rendered: the frame, and the photons behind it in world space.
pub struct HardFrame {
    pub frame: FrameImage,
    /// The photon map, positions in world space.
    pub photons: Vec<Photon>,
    /// The bounce map, one record per light-G-buffer texel.
    pub bounce_map: Vec<BounceMapPhoton>,
    /// The photon frame's budget: bounce-map texels per light view, in plan order, and the
    /// light each view belongs to.
    pub view_texels: Vec<(usize, usize)>,
    /// Most bounces the frame's photon trace took (the effects plan's).
    pub max_bounces: u32,
    /// The largest photon kernel radius the frame used (m; 0 without photons).
    pub r_max: f32,
    /// The world-space surface point of each pixel (`None` where the eye sees nothing), from
    /// the eye G-buffer.
    pub positions: Vec<Option<Vec3>>,
}

impl HardFrame {
    /// Linear RGB of pixel (x, y).
    pub fn pixel(&self, x: u32, y: u32) -> Vec3 {
        let i = ((y * self.frame.width + x) * 4) as usize;
        Vec3::new(
            self.frame.hdr[i],
            self.frame.hdr[i + 1],
            self.frame.hdr[i + 2],
        )
    }

    /// Mean linear RGB over the pixels where `keep(x, y)`.
    pub fn mean_where(&self, keep: impl Fn(u32, u32) -> bool) -> Vec3 {
        let (mut sum, mut n) = (Vec3::ZERO, 0u32);
        for y in 0..self.frame.height {
            for x in 0..self.frame.width {
                if keep(x, y) {
                    sum += self.pixel(x, y);
                    n += 1;
                }
            }
        }
        sum / n.max(1) as f32
    }

    /// Mean linear RGB of the whole frame.
    pub fn mean(&self) -> Vec3 {
        self.mean_where(|_, _| true)
    }

    /// Largest channel value of the frame.
    pub fn peak(&self) -> f32 {
        self.frame
            .hdr
            .chunks_exact(4)
            .fold(0.0f32, |m, p| m.max(p[0]).max(p[1]).max(p[2]))
    }

    /// Σ of the bounce map's powers (W, RGB), in f64.
    pub fn bounce_map_power(&self) -> glam::DVec3 {
        self.bounce_map.iter().map(|p| p.power.as_dvec3()).sum()
    }

    /// Σ of the photon map's powers (W, RGB), in f64.
    pub fn stored_power(&self) -> glam::DVec3 {
        self.photons.iter().map(|p| p.power.as_dvec3()).sum()
    }
}

/// Σ flux of the scene's lights (W, mean of RGB), in f64.
pub fn total_flux(scene: &Scene) -> f64 {
    let bounds = scene.bounds();
    scene
        .lights
        .iter()
        .map(|l| f64::from(ispm::photon::emit::light_flux(l, &bounds).element_sum()) / 3.0)
        .sum()
}

/// The catalogue's settings: `SIZE`², `photons` photons, 256² shadow maps.
pub fn settings_for(photons: usize) -> RenderSettings {
    RenderSettings {
        method: Method::Ispm,
        photons,
        width: SIZE,
        height: SIZE,
        shadow_resolution: 256,
        ..Default::default()
    }
}

/// [`settings_for`] with one bounce, for the cases that check the bounce map and direct light in
/// boxes of albedo 1: there Russian roulette never ends a path, so the default cap (256 bounces)
/// would trace 256 times the photons for nothing the case reads.
pub fn first_bounce_for(photons: usize) -> RenderSettings {
    RenderSettings {
        bounces: 1,
        ..settings_for(photons)
    }
}

/// A scene written by `ispm::scene::authoring` (a `.glb` in memory), through the loader.
pub fn load_glb(name: &str, glb: &[u8]) -> Scene {
    ispm::scene::load::load_from_slice(glb, name, None).expect("the authored scene loads")
}

fn finite(v: Vec3) -> bool {
    v.is_finite()
}

/// What is wrong with the photons, the bounce map and the frame, one line per kind.
fn problems(frame: &FrameImage, photons: &[Photon], bounce: &[BounceMapPhoton]) -> Vec<String> {
    let mut out = Vec::new();
    let bad_hdr = frame
        .hdr
        .iter()
        .filter(|v| !v.is_finite() || **v < 0.0)
        .count();
    if bad_hdr > 0 {
        out.push(format!("{bad_hdr} NaN, infinite or negative HDR values"));
    }
    let bad_photons = photons
        .iter()
        .filter(|p| {
            !(finite(p.power) && finite(p.direction) && finite(p.position) && finite(p.normal))
                || p.power.min_element() < 0.0
        })
        .count();
    if bad_photons > 0 {
        out.push(format!(
            "{bad_photons} photon(s) with non-finite or negative values"
        ));
    }
    let bad_records = bounce
        .iter()
        .filter(|p| {
            !(finite(p.power) && finite(p.direction) && p.eta.is_finite() && p.depth.is_finite())
                || p.power.min_element() < 0.0
        })
        .count();
    if bad_records > 0 {
        out.push(format!(
            "{bad_records} bounce-map record(s) with non-finite or negative values"
        ));
    }
    out
}

/// Renders `scene` with `settings` (its method forced to ISPM) end to end and checks what every
/// hard case must hold (module docs); `case` names the failure images' folder.
pub fn render_hard(case: &str, scene: &Scene, settings: RenderSettings) -> HardFrame {
    let gpu = super::gpu();
    let settings = RenderSettings {
        method: Method::Ispm,
        check_values: true,
        ..settings
    };
    let hard = {
        let mut renderer = Renderer::new(&gpu, scene, settings).expect("renderer");
        let frame = renderer.render().expect("render");
        let eye = renderer.camera().position();
        let max_bounces = renderer.plan().max_bounces;
        let r_max = renderer.photons().map_or(0.0, |p| p.kernel().r_max);
        let gbuffer: Vec<[f32; 4]> =
            bytemuck::pod_collect_to_vec(&renderer.read_gbuffer("position").expect("position"));
        // Camera-relative in the G-buffer; w = 0 where nothing was drawn.
        let positions = gbuffer
            .iter()
            .map(|p| (p[3] != 0.0).then(|| Vec3::new(p[0], p[1], p[2]) + eye))
            .collect();
        let (photons, bounce_map, view_texels) = match renderer.photons() {
            Some(p) => (
                p.photon_map()
                    .into_iter()
                    .map(|ph| Photon {
                        position: ph.position + eye,
                        ..ph
                    })
                    .collect(),
                p.bounce_map().to_vec(),
                p.plan()
                    .extents
                    .iter()
                    .zip(&p.plan().view_lights)
                    .map(|(&(w, h), &l)| ((w * h) as usize, l))
                    .collect(),
            ),
            None => (Vec::new(), Vec::new(), Vec::new()),
        };
        HardFrame {
            frame,
            photons,
            bounce_map,
            view_texels,
            max_bounces,
            r_max,
            positions,
        }
    };
    let mut wrong = problems(&hard.frame, &hard.photons, &hard.bounce_map);
    match &hard.frame.stats.value_check {
        Some(check) if check.total_bad() == 0 => {}
        Some(check) => wrong.push(format!("GPU value check: {check:?}")),
        None => wrong.push("no GPU value check".into()),
    }
    wrong.extend(gpu.validation_messages());
    if !wrong.is_empty() {
        save(case, &hard.frame);
        panic!("{case}:\n{}", wrong.join("\n"));
    }
    hard
}

/// The same frame with `--method direct` (shadow-mapped direct light only, no noise), on a
/// validation-enabled device.
pub fn render_direct(scene: &Scene, settings: RenderSettings) -> FrameImage {
    let gpu = super::gpu();
    let settings = RenderSettings {
        method: Method::Direct,
        ..settings
    };
    let frame = Renderer::new(&gpu, scene, settings)
        .and_then(|mut r| r.render())
        .expect("direct render");
    super::assert_validation_clean(&gpu);
    frame
}

/// Writes the frame's HDR (EXR) and tonemapped (PNG) images under the case's test-image folder.
pub fn save(case: &str, frame: &FrameImage) {
    let dir = super::image_dir(case);
    let exr = dir.join("actual.exr");
    let png = dir.join("actual.png");
    ispm::output::write_exr(&exr, frame.width, frame.height, &frame.hdr).expect("write EXR");
    ispm::output::write_png(&png, frame.width, frame.height, &frame.ldr).expect("write PNG");
    eprintln!("wrote {} and {}", exr.display(), png.display());
}

/// Fails (writing both frames) unless `a` and `b` agree: the mean over pixels and channels of
/// |a − b| is at most `tolerance` times the mean of `b`. Returns that relative difference.
pub fn assert_same_image(case: &str, a: &FrameImage, b: &FrameImage, tolerance: f64) -> f64 {
    let diff: f64 = a
        .hdr
        .chunks_exact(4)
        .zip(b.hdr.chunks_exact(4))
        .map(|(p, q)| (0..3).map(|c| f64::from((p[c] - q[c]).abs())).sum::<f64>())
        .sum();
    let level: f64 = b
        .hdr
        .chunks_exact(4)
        .map(|q| (0..3).map(|c| f64::from(q[c])).sum::<f64>())
        .sum();
    let relative = diff / level.max(1e-30);
    eprintln!("{case}: mean |a − b| / mean b = {relative:.3e} (tolerance {tolerance:.1e})");
    if relative.is_nan() || relative > tolerance {
        super::golden::write_failure_images(case, a.width, a.height, &a.hdr, Some(&b.hdr));
        panic!("{case}: images differ by {relative:.3e} of the reference (> {tolerance:.1e})");
    }
    relative
}

/// The stage most cases stand on: a 3 m white diffuse floor at y = 0 (material 0) and a camera
/// 2.2 m up and 2.2 m back looking at the origin. Returns the floor's material.
pub fn stage(w: &mut GltfWriter) -> usize {
    let floor = w.material(&MaterialSpec::diffuse("floor", [0.75; 3]));
    let mesh = w.mesh("floor", &quad(Vec3::ZERO, Vec3::Y, 1.5, 1.5), floor);
    w.mesh_node("floor", mesh, Vec3::ZERO, Quat::IDENTITY);
    w.camera("camera", Vec3::new(0.0, 2.2, 2.2), Vec3::ZERO, 0.8);
    floor
}

/// A 4 W/sr white spot 2 m above the origin aiming down (cone 0.6…0.8 rad).
pub fn overhead_spot(w: &mut GltfWriter) {
    let at = Vec3::new(0.0, 2.0, 0.0);
    w.spot("spot", at, Vec3::ZERO, [1.0; 3], 4.0, (0.6, 0.8));
}

/// A [`Mesh`] of authored geometry (for scenes built directly, past the loader's repairs).
pub fn mesh_of(name: &str, g: &Geometry, material: usize) -> Mesh {
    Mesh {
        name: name.into(),
        positions: g.positions.clone(),
        normals: g.normals.clone(),
        uvs: g.uvs.clone(),
        triangles: g
            .indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect(),
        material,
    }
}

/// Adds `mesh` to `scene` as one instance at `transform`.
pub fn add_mesh(scene: &mut Scene, mesh: Mesh, transform: Mat4) {
    scene.instances.push(Instance {
        name: mesh.name.clone(),
        mesh: scene.meshes.len(),
        transform,
    });
    scene.meshes.push(mesh);
}

/// A camera at `eye` looking at `target` (not straight up or down).
pub fn camera_looking(eye: Vec3, target: Vec3, yfov: f32) -> Camera {
    let view = glam::camera::rh::view::look_at_mat4(eye, target, Vec3::Y);
    Camera {
        transform: view.inverse(),
        yfov,
        znear: 1e-3,
        zfar: None,
    }
}
