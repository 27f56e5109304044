//! What the hard-case tests (docs/stability.md) share: a small lit box authored at any scale
//! and place, a frame rendered with the GPU value check on, and the assertions every case
//! makes (no bad value in any buffer, a finite non-negative EXR, validation silent).

use glam::{Quat, Vec3};
use ispm::frame::{FrameImage, RenderSettings, Renderer};
use ispm::gpu::Gpu;
use ispm::scene::authoring::{cuboid, icosphere, quad, GltfWriter, MaterialSpec};
use ispm::scene::Scene;

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
    let white = room(&mut w, scale, offset);
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
        let white = room(&mut w, 1.0, Vec3::new(x, 0.0, 0.0));
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

/// The five walls of a 2 m room (module docs of [`lit_box`]), scaled and moved; returns the
/// white material.
fn room(w: &mut GltfWriter, scale: f32, offset: Vec3) -> usize {
    let white = w.material(&MaterialSpec::diffuse("white", [0.75, 0.75, 0.75]));
    let red = w.material(&MaterialSpec::diffuse("red", [0.63, 0.065, 0.05]));
    let green = w.material(&MaterialSpec::diffuse("green", [0.14, 0.45, 0.091]));
    let walls = [
        ("floor", Vec3::ZERO, Vec3::Y, white),
        ("ceiling", Vec3::new(0.0, 2.0, 0.0), Vec3::NEG_Y, white),
        ("back", Vec3::new(0.0, 1.0, -1.0), Vec3::Z, white),
        ("left", Vec3::new(-1.0, 1.0, 0.0), Vec3::X, red),
        ("right", Vec3::new(1.0, 1.0, 0.0), Vec3::NEG_X, green),
    ];
    for (name, c, n, m) in walls {
        // Centred on the node, so the vertices stay small and the node carries the offset.
        let mesh = w.mesh(name, &quad(Vec3::ZERO, n, scale, scale), m);
        w.mesh_node(name, mesh, offset + c * scale, Quat::IDENTITY);
    }
    white
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
