//! `ispm view`: the live window (`ispm::viewer`).

use super::{load_scene_from, parse_seconds_per_turn, parse_size, QualityArgs, SceneArgs};
use ispm::output::OutputFormat;
use ispm::settings::{Density, Knobs, RenderSettings};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct ViewArgs {
    /// A .gltf/.glb file or a bundled scene name (default: the bundled cornell-box).
    scene: Option<String>,
    #[command(flatten)]
    scene_args: SceneArgs,
    /// Window (and render) size, WIDTHxHEIGHT.
    #[arg(long, default_value = "960x540", value_parser = parse_size)]
    size: (u32, u32),
    #[command(flatten)]
    quality: QualityArgs,
    /// Render N frames along the scripted camera path, write --screenshot of the last and
    /// exit (the viewer's smoke test).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    frames: Option<u32>,
    /// The density estimator: `volumes` (each photon's kernel rasterised as a
    /// billboard, the paper's), `tiled` (a per-tile gather in compute; the same sums) or `auto`
    /// (the faster on this device: tiled on a CPU implementation such as lavapipe, volumes on
    /// a GPU; `ispm info` says which).
    #[arg(long, value_enum, default_value_t)]
    density: Density,
    /// GPU methods: levels of the edge-avoiding à-trous filter over the indirect light (taps up
    /// to ±2·(2^N − 1) pixels apart, on one surface), fewer as still frames accumulate and none
    /// from the 2^N-th on, so the mean converges as without it (0: the raw estimate;
    /// docs/accuracy.md, "The denoiser").
    #[arg(long, value_name = "N", default_value_t = ispm::passes::denoise::DEFAULT_LEVELS,
          value_parser = clap::value_parser!(u32).range(0..=ispm::passes::denoise::MAX_LEVELS as i64))]
    denoise: u32,
    /// Every frame stands alone: no progressive accumulation while the view stands still.
    #[arg(long)]
    no_accumulate: bool,
    /// Where --frames writes the last frame (PNG).
    #[arg(long, requires = "frames")]
    screenshot: Option<PathBuf>,
    /// Resize the window after FRAME frames to WxH (FRAME:WxH; tests drive a resize).
    #[arg(long, hide = true, value_parser = parse_resize)]
    resize_at: Option<(u32, (u32, u32))>,
    /// Where the P (screenshot + stats) and T (trace) keys write (default: the current
    /// directory).
    #[arg(long, value_name = "DIR")]
    shots: Option<PathBuf>,
    /// Start showing an intermediate buffer instead of the frame (the overlay switches them).
    #[arg(long, value_enum)]
    debug_view: Option<ispm::passes::debug_view::DebugView>,
    /// Start with the overlay shown (Tab toggles it).
    #[arg(long, hide = true)]
    overlay: bool,
    /// Press KEY (p, t or tab) at the start of frame FRAME (FRAME:KEY; tests simulate keys).
    #[arg(long, hide = true, value_parser = parse_press)]
    press: Vec<(u32, ispm::viewer::ViewKey)>,
    /// Start from the file's camera N (0-based, in node order; default: the first).
    #[arg(long, value_name = "N")]
    camera: Option<usize>,
    /// Orbit every light about the vertical axis through the scene's centre, one turn per
    /// SECONDS_PER_TURN (default 10), so any scene shows moving light and caustics.
    #[arg(long, value_name = "SECONDS_PER_TURN", num_args = 0..=1, default_missing_value = "10",
          value_parser = parse_seconds_per_turn)]
    orbit_lights: Option<f32>,
}

fn parse_resize(s: &str) -> Result<(u32, (u32, u32)), String> {
    let (frame, size) = s
        .split_once(':')
        .ok_or_else(|| format!("{s:?} is not FRAME:WxH"))?;
    let frame = frame
        .parse()
        .map_err(|_| format!("{s:?} is not FRAME:WxH"))?;
    Ok((frame, parse_size(size)?))
}

fn parse_press(s: &str) -> Result<(u32, ispm::viewer::ViewKey), String> {
    use ispm::viewer::ViewKey;
    let bad = || format!("{s:?} is not FRAME:KEY with KEY p, t or tab");
    let (frame, key) = s.split_once(':').ok_or_else(bad)?;
    let frame: u32 = frame.parse().map_err(|_| bad())?;
    let key = match key.to_ascii_lowercase().as_str() {
        "p" => ViewKey::Screenshot,
        "t" => ViewKey::Trace,
        "tab" => ViewKey::ToggleOverlay,
        _ => return Err(bad()),
    };
    Ok((frame, key))
}

pub fn view(args: ViewArgs, device: Option<usize>) -> anyhow::Result<()> {
    if let Some(path) = &args.screenshot {
        anyhow::ensure!(
            OutputFormat::from_path(path)? == OutputFormat::Png,
            "{}: the screenshot is a PNG",
            path.display()
        );
        ispm::output::check_writable(path)?;
    }
    if let Some(dir) = &args.shots {
        anyhow::ensure!(
            dir.is_dir(),
            "--shots {}: not a directory (the P and T keys write into it)",
            dir.display()
        );
    }
    let scene = load_scene_from(
        args.scene.as_deref(),
        &args.scene_args,
        args.camera,
        args.orbit_lights,
    )?;
    let knobs = Knobs {
        size: Some(args.size),
        accumulate: Some(!args.no_accumulate),
        density: Some(args.density),
        denoise: Some(args.denoise),
        ..args.quality.knobs(Some(ispm::quality::VIEW_DEFAULT))
    };
    let settings = ispm::viewer::ViewSettings {
        render: RenderSettings::from_knobs(&knobs, &scene.bounds())?,
        device_index: device,
        frames: args.frames,
        screenshot: args.screenshot,
        resize_at: args.resize_at,
        overlay: args.overlay,
        debug_view: args.debug_view,
        shots: args.shots,
        presses: args.press,
    };
    let report = ispm::viewer::run(scene, settings)?;
    log::info!(
        "{} frames, {} swapchain(s) recreated, overlay drawn in {} (at most {} vertices)",
        report.frames,
        report.recreated,
        report.overlay_frames,
        report.overlay_vertices
    );
    if !report.validation_messages.is_empty() {
        for m in &report.validation_messages {
            eprintln!("{m}");
        }
        anyhow::bail!("{} validation message(s)", report.validation_messages.len());
    }
    Ok(())
}
