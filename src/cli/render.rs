//! `ispm render`: one picture, headless: the GPU renderer's frames accumulated for `--seconds`
//! or `--frames`, or a CPU reference.

use super::{check_validation, gpu, parse_size, EstimateArgs, OrbitArgs, QualityArgs, SceneArgs};
use anyhow::Context;
use ispm::config::settings::{
    Effects, Knobs, Method, RenderSettings, Schedule, Tonemap, CAUSTIC_SHARE,
    DEFAULT_EMITTER_LIGHTS, DEFAULT_EXPOSURE_EV, DEFAULT_SEED, DEFAULT_SHADOW_RESOLUTION,
};
use ispm::output::{write_exr, write_png, OutputFormat};
use ispm::render::frame::Renderer;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct RenderArgs {
    #[command(flatten)]
    scene_args: SceneArgs,
    /// Output image: .png (tonemapped sRGB) or .exr (linear HDR).
    #[arg(short, long, default_value = "out.png")]
    output: PathBuf,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "640x480", value_parser = parse_size)]
    size: (u32, u32),
    #[arg(long, value_enum, default_value_t)]
    method: Method,
    #[command(flatten)]
    quality: QualityArgs,
    /// Eye samples per pixel (CPU references).
    #[arg(long, default_value_t = 16)]
    spp: u32,
    /// GPU methods: frames to render; the image is their mean (progressive accumulation: each
    /// frame traces new photons with smaller kernels), the stats the last one's. Without it,
    /// frames accumulate for --seconds. `progressive`: its iterations (default 16).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    frames: Option<u32>,
    /// GPU methods without --frames: accumulate frames for about this long, from the first
    /// frame to the picture (at least one frame; frames still in flight are counted in).
    #[arg(long, default_value_t = DEFAULT_RENDER_SECONDS, value_parser = parse_seconds)]
    seconds: f64,
    /// GPU methods: every frame stands alone (no accumulation); the image is the last frame.
    #[arg(long)]
    no_accumulate: bool,
    #[command(flatten)]
    estimate: EstimateArgs,
    /// GPU methods: `overlapped` traces the photons on the CPU while the GPU draws the eye
    /// G-buffer and direct light and keeps frames in flight (the paper's Figure 3); `auto` does
    /// the same except on a CPU device (lavapipe), whose passes run on the cores the trace
    /// would use, where the trace waits for them; `serial` runs every step strictly after the
    /// one before.
    #[arg(long, value_enum, default_value_t)]
    schedule: Schedule,
    /// Seed of every random choice.
    #[arg(long, default_value_t = DEFAULT_SEED)]
    seed: u32,
    /// GPU methods: `auto` skips the passes, shader variants, lights and bounces the scene
    /// does not need (`ispm plan` prints why); `all` runs everything (the unplanned frame).
    #[arg(long, value_enum, default_value_t)]
    effects: Effects,
    /// Write the frame's statistics (the paper's Table 2 columns) as JSON.
    #[arg(long)]
    stats: Option<PathBuf>,
    /// Write a Chrome Trace Event JSON of every frame (GPU passes per queue, CPU work per
    /// thread, on one clock); open it in ui.perfetto.dev.
    #[arg(long)]
    trace: Option<PathBuf>,
    /// Display transform for PNG output.
    #[arg(long, value_enum, default_value_t)]
    tonemap: Tonemap,
    /// Exposure in stops (radiance × 2^EV before tonemapping).
    #[arg(long, default_value_t = DEFAULT_EXPOSURE_EV, allow_hyphen_values = true)]
    exposure: f32,
    /// Shadow-map resolution per light view.
    #[arg(long, default_value_t = DEFAULT_SHADOW_RESOLUTION)]
    shadow_resolution: u32,
    /// Smallest share (0 to 0.95) of each light's photons spent on its caustic views: windows
    /// of its views around the mirrors and glass it lights, at a higher texel density (0: none).
    #[arg(long, default_value_t = CAUSTIC_SHARE, value_parser = parse_share)]
    caustic_share: f32,
    /// Points sampled on the emissive surfaces per frame, each a shadow-mapped light that emits
    /// photons (new points every accumulated frame; 0: emitters are seen but light nothing).
    #[arg(long, value_name = "N", default_value_t = DEFAULT_EMITTER_LIGHTS)]
    emitter_lights: u32,
    /// Render from the pose of frame K of `ispm view --frames`'s scripted camera path (which
    /// starts at the --camera one): the headless twin of the viewer's screenshot.
    #[arg(long, value_name = "K")]
    camera_path_frame: Option<u32>,
    #[command(flatten)]
    orbit: OrbitArgs,
    /// Render the scene as it is SECONDS into its motion (glTF animations, --orbit-lights).
    #[arg(long, value_name = "SECONDS", default_value_t = 0.0, value_parser = parse_time)]
    time: f32,
    /// GPU methods: write an intermediate buffer, false-coloured, instead of the frame (the
    /// viewer's debug views; PNG output).
    #[arg(long, value_enum)]
    debug_view: Option<ispm::passes::debug_view::DebugView>,
    /// GPU methods: count NaN, ±Inf and negative values in every HDR buffer (direct, bounce
    /// map, photon map, indirect, final) on the GPU; the counts go to --stats, and a frame
    /// with any is reported on stderr.
    #[arg(long)]
    check_values: bool,
}

fn parse_share(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if (0.0..=0.95).contains(&v) => Ok(v),
        _ => Err(format!(
            "caustic share {s:?} is not a number from 0 to 0.95"
        )),
    }
}

fn parse_time(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("time {s:?} is not a number of seconds ≥ 0")),
    }
}

/// How long `ispm render` accumulates by default (`--seconds`).
const DEFAULT_RENDER_SECONDS: f64 = 4.0;

/// A duration in seconds: finite and not negative.
fn parse_seconds(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("{s} is not a duration in seconds (a number ≥ 0)")),
    }
}

pub fn render(args: RenderArgs, device: Option<usize>) -> anyhow::Result<()> {
    let format = OutputFormat::from_path(&args.output)?;
    // Outputs that cannot be written fail before any work, so none is left half done.
    for path in [Some(&args.output), args.stats.as_ref(), args.trace.as_ref()]
        .into_iter()
        .flatten()
    {
        ispm::output::check_writable(path)?;
    }
    let scene = args.scene_args.load(&args.orbit)?;
    // ISPM starts from a preset; direct light and the CPU references from the flags' own
    // defaults.
    let default = (args.method == Method::Ispm).then_some(ispm::config::quality::RENDER_DEFAULT);
    let knobs = Knobs {
        method: Some(args.method),
        size: Some(args.size),
        seed: Some(args.seed),
        shadow_resolution: Some(args.shadow_resolution),
        tonemap: Some(args.tonemap),
        exposure_ev: Some(args.exposure),
        schedule: Some(args.schedule),
        density: Some(args.estimate.density),
        denoise: Some(args.estimate.denoise),
        effects: Some(args.effects),
        caustic_share: Some(args.caustic_share),
        emitter_lights: Some(args.emitter_lights),
        check_values: Some(args.check_values),
        accumulate: Some(!args.no_accumulate),
        ..args.quality.knobs(default)
    };
    let settings = RenderSettings::from_knobs(&knobs, &scene.bounds())?;
    // The viewer's scripted path starts from the scene as loaded.
    let path_pose = args
        .camera_path_frame
        .map(|k| ispm::app::camera_control::scripted_pose(&scene.camera, &scene.bounds(), k));
    let mut scene = scene.posed(args.time);
    if let Some(camera) = path_pose {
        scene.camera = camera;
    }
    if !settings.method.is_gpu() {
        anyhow::ensure!(
            args.debug_view.is_none(),
            "--debug-view shows the GPU methods' buffers (ispm, direct) only"
        );
        if let Some(trace) = &args.trace {
            anyhow::bail!(
                "{}: --trace records the GPU methods (ispm, direct) only",
                trace.display()
            );
        }
        return render_reference(&args, &settings, &scene, format);
    }
    if let Some(view) = args.debug_view {
        anyhow::ensure!(
            format == OutputFormat::Png || view == ispm::passes::debug_view::DebugView::DirectOnly,
            "{}: --debug-view {view:?} is an 8-bit false-colour image: write a .png",
            args.output.display()
        );
    }
    let gpu = gpu(device)?;
    if args.trace.is_some() {
        ispm::timing::start_capture();
    }
    let (frame, triangles) = {
        let mut renderer = Renderer::new(&gpu, &scene, settings.clone())?;
        renderer
            .set_debug_view(args.debug_view)
            .context("--debug-view")?;
        // --frames N: exactly N frames; otherwise as many as --seconds allows (one frame
        // without accumulation, where more would only repeat it), counting the frames still in
        // flight: a frame is submitted only while the time so far, it and the frames after it
        // (the ones in flight and the last, which `render` submits) fit in --seconds.
        let start = std::time::Instant::now();
        let mut submitted = 1;
        let mut last_return = 0.0f64;
        let mut period = 0.0f64;
        loop {
            let elapsed = start.elapsed().as_secs_f64();
            let more = match args.frames {
                Some(n) => submitted < n,
                None => {
                    // This frame and the FRAMES_IN_FLIGHT after it finishing (the frames in
                    // flight overlap them and the last frame, which `render` submits, is one
                    // of them): it may run over by a frame's period, and stops early by as much.
                    let to_finish = (ispm::config::settings::FRAMES_IN_FLIGHT + 1) as f64 * period;
                    !args.no_accumulate
                        && renderer.plan().accumulate
                        && elapsed + to_finish < args.seconds
                }
            };
            if !more {
                break;
            }
            renderer.submit_frame()?;
            submitted += 1;
            // The interval between the last two submissions returning: once frames are in
            // flight, a submission waits for the frame two before it, so this is the period.
            let now = start.elapsed().as_secs_f64();
            period = now - last_return;
            last_return = now;
        }
        (renderer.render()?, renderer.triangles())
    };
    let capture = ispm::timing::finish_capture();
    check_validation(&gpu)?;
    match format {
        OutputFormat::Png => {
            write_png(&args.output, frame.width, frame.height, &frame.ldr)?;
            // Never a silent black picture: a dark one says which exposure would show it.
            if let Some(ev) = ispm::output::exposure_hint(&frame.hdr, &frame.ldr) {
                eprintln!(
                    "note: {} came out nearly black at --exposure {}; --exposure {ev} brings its \
                     lit pixels to mid-grey",
                    args.output.display(),
                    args.exposure
                );
            }
        }
        OutputFormat::Exr => write_exr(&args.output, frame.width, frame.height, &frame.hdr)?,
    }
    if let Some(path) = &args.stats {
        let json = ispm::render::stats::frame_json(
            &scene,
            &frame,
            triangles,
            settings.bounces,
            gpu.validation_message_count(),
        );
        ispm::output::write_atomically(path, |f| {
            serde_json::to_writer_pretty(f, &json)
                .with_context(|| format!("{}: cannot write JSON", path.display()))
        })?;
    }
    if let Some(path) = &args.trace {
        capture.write_chrome(path)?;
    }
    for s in &frame.gpu_spans {
        log::info!("{:>16}: {:.3} ms", s.name, s.ms());
    }
    if let Some(check) = &frame.stats.value_check {
        for b in check
            .per_buffer
            .iter()
            .filter(|b| b.non_finite + b.negative > 0)
        {
            eprintln!(
                "value check: {}: {} non-finite and {} negative of {} values",
                b.name, b.non_finite, b.negative, b.values
            );
        }
    }
    let capped = &frame.stats.lights_at_max_resolution;
    if !capped.is_empty() {
        let names: Vec<&str> = capped
            .iter()
            .map(|&l| scene.lights[l].name.as_str())
            .collect();
        let side = ispm::plan::bounce_plan::MAX_RESOLUTION;
        eprintln!(
            "note: the photon budget of light {} asks for light views past the largest \
             ({side}x{side} texels): the frame emits {} photons of the {} asked",
            names.join(", light "),
            frame.stats.emitted_photons,
            settings.photons
        );
    }
    eprintln!(
        "wrote {} ({}x{}, {} triangles, {} lights{}, {} photons emitted and {} stored per frame, \
         mean of {} frame{})",
        args.output.display(),
        frame.width,
        frame.height,
        triangles,
        scene.lights.len(),
        match frame
            .stats
            .light_plan
            .len()
            .saturating_sub(scene.lights.len())
        {
            0 => String::new(),
            n => format!(" and {n} points on its emitters"),
        },
        frame.stats.emitted_photons,
        frame.stats.stored_photons,
        frame.stats.accumulated_frames,
        if frame.stats.accumulated_frames == 1 {
            ""
        } else {
            "s"
        }
    );
    Ok(())
}

/// `render` with a CPU reference (`settings.method`): an EXR of `settings`' size, photons,
/// bounces, radius and seed.
fn render_reference(
    args: &RenderArgs,
    settings: &RenderSettings,
    scene: &ispm::scene::Scene,
    format: OutputFormat,
) -> anyhow::Result<()> {
    anyhow::ensure!(
        format == OutputFormat::Exr,
        "{}: the CPU references write linear EXR (use a .exr file name)",
        args.output.display()
    );
    let method = settings.method;
    let settings = ispm::reference::RefSettings {
        width: settings.width,
        height: settings.height,
        spp: args.spp.max(1),
        photons: settings.photons,
        bounces: settings.bounces,
        iterations: args.frames.unwrap_or(16),
        radius: settings.radius,
        seed: settings.seed,
        ..Default::default()
    };
    let cancel = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    {
        let cancel = cancel.clone();
        // Ctrl-C stops after the current pass and keeps the last complete image.
        let _ = ctrlc::set_handler(move || cancel.store(true, std::sync::atomic::Ordering::SeqCst));
    }
    let progress = indicatif::ProgressBar::new(0);
    if !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        progress.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let image = ispm::reference::render(scene, method, &settings, Some(&progress), &cancel)?;
    progress.finish_and_clear();
    image.write_exr(&args.output)?;
    eprintln!(
        "wrote {} ({}x{})",
        args.output.display(),
        image.width,
        image.height
    );
    Ok(())
}
