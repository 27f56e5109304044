//! `ispm view`: the live window (`ispm::app::viewer`).

use super::{parse_size, EstimateArgs, OrbitArgs, QualityArgs, SceneArgs};
use ispm::config::settings::{Knobs, RenderSettings};
use ispm::output::OutputFormat;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct ViewArgs {
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
    #[command(flatten)]
    estimate: EstimateArgs,
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
    press: Vec<(u32, ispm::app::viewer::ViewKey)>,
    #[command(flatten)]
    orbit: OrbitArgs,
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

fn parse_press(s: &str) -> Result<(u32, ispm::app::viewer::ViewKey), String> {
    use ispm::app::viewer::ViewKey;
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
    let scene = args.scene_args.load(&args.orbit)?;
    let knobs = Knobs {
        size: Some(args.size),
        accumulate: Some(!args.no_accumulate),
        density: Some(args.estimate.density),
        denoise: Some(args.estimate.denoise),
        ..args
            .quality
            .knobs(Some(ispm::config::quality::VIEW_DEFAULT))
    };
    let settings = ispm::app::viewer::ViewSettings {
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
    let report = ispm::app::viewer::run(scene, settings)?;
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
