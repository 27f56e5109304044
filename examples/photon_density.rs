//! The power density of the photons an ISPM frame stores on the ground plane (y = 0), seen from
//! above, as a greyscale PNG: where the caustics land, whatever the camera sees.
//!
//! ```sh
//! cargo run --release --example photon_density -- SCENE OUT.png [SHARE] [HALF_SIZE] [WHITE]
//! ```
//!
//! SHARE: the caustic share (default: the renderer's); HALF_SIZE: half the side of the square
//! around the origin, in metres (0.6); WHITE: the density shown white, in W/m² (15).
//! docs/accuracy.md §3 shows `caustic-ring` at caustic shares 0 and 0.5.

use anyhow::Context;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [scene, out, rest @ ..] = args.as_slice() else {
        anyhow::bail!("usage: photon_density SCENE OUT.png [CAUSTIC_SHARE] [HALF_SIZE_M] [WHITE]");
    };
    let number = |i: usize, default: f32| -> anyhow::Result<f32> {
        rest.get(i)
            .map_or(Ok(default), |v| v.parse().context("not a number"))
    };
    let defaults = ispm::config::settings::RenderSettings::default();
    let (share, half, white) = (
        number(0, defaults.caustic_share)?,
        number(1, 0.6)?,
        number(2, 15.0)?,
    );
    let scene = ispm::scene::bundled::resolve(Some(scene))?;
    let gpu = ispm::gpu::Gpu::new(&Default::default())?;
    let settings = ispm::config::settings::RenderSettings {
        width: 16,
        height: 16,
        caustic_share: share,
        ..defaults
    };
    let mut renderer = ispm::render::frame::Renderer::new(&gpu, &scene, settings)?;
    let frame = renderer.render()?;
    let camera = scene.camera.position();
    let n = 200usize;
    let mut density = vec![0.0f32; n * n];
    let cell = 2.0 * half / n as f32;
    for p in renderer
        .photons()
        .context("not an ISPM frame")?
        .photon_map()
    {
        let w = p.position + camera;
        let (x, z) = ((w.x + half) / cell, (w.z + half) / cell);
        if w.y.abs() < 0.02 && (0.0..n as f32).contains(&x) && (0.0..n as f32).contains(&z) {
            density[z as usize * n + x as usize] += p.power.x / (cell * cell);
        }
    }
    let rgba: Vec<u8> = density
        .iter()
        .flat_map(|v| {
            let c = ((v / white).clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0) as u8;
            [c, c, c, 255]
        })
        .collect();
    ispm::output::write_png(std::path::Path::new(out), n as u32, n as u32, &rgba)?;
    eprintln!(
        "wrote {out}: {} photons stored, caustic share {share}",
        frame.stats.stored_photons
    );
    Ok(())
}
