//! `ispm bench`: the frame's cost per stage, schedules side by side (`ispm::bench`).

use super::{
    check_validation, gpu, load_scene_from, parse_seconds_per_turn, parse_size, QualityArgs,
    SceneArgs,
};
use anyhow::Context;
use ispm::settings::{Density, Knobs, Schedule, DEFAULT_SHADOW_RESOLUTION};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct BenchArgs {
    /// A .gltf/.glb file or a bundled scene name (default: the bundled cornell-box).
    scene: Option<String>,
    #[command(flatten)]
    scene_args: SceneArgs,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "1280x720", value_parser = parse_size)]
    size: (u32, u32),
    /// Measured frames per configuration (after warm-up).
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(1..))]
    frames: u32,
    /// Warm-up frames per configuration.
    #[arg(long, default_value_t = 2)]
    warmup: u32,
    /// Chunks the frames are split into, alternating the configurations.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..))]
    chunks: u32,
    #[command(flatten)]
    quality: QualityArgs,
    /// Shadow-map resolution per light view.
    #[arg(long, default_value_t = DEFAULT_SHADOW_RESOLUTION)]
    shadow_resolution: u32,
    /// Write the figures as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write an SVG of the last overlapped chunk's schedule (the paper's Figure 3).
    #[arg(long)]
    figure: Option<PathBuf>,
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
    /// The schedule measured against the serial one: `auto` (the default: the paper's
    /// overlapped frame, except that on a CPU device such as lavapipe the trace waits for the
    /// passes that would share its cores) or `overlapped` (the paper's order on every device);
    /// `serial` measures `auto`.
    #[arg(long, value_enum, default_value_t)]
    schedule: Schedule,
    /// Also measure the other density estimator (overlapped, `--effects all`) in the same
    /// alternating chunks: `density_speedup` = its frame period ÷ the overlapped one's.
    #[arg(long)]
    compare_density: bool,
    /// Also measure the overlapped frame with the indirect light estimated at 1/N resolution
    /// (`--subsample N`) in the same alternating chunks: `subsample_speedup` says how many
    /// times cheaper its radiance estimate (density pass + upsample) and frame are.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=64))]
    compare_subsample: Option<u32>,
    /// Also measure the frame as the effects plan makes it (`--effects auto`) against the
    /// overlapped frame, which runs every pass and variant (`--effects all`), in the same
    /// alternating chunks.
    #[arg(long)]
    compare_effects: bool,
    /// Render from the file's camera N (0-based, in node order; default: the first).
    #[arg(long, value_name = "N")]
    camera: Option<usize>,
    /// Orbit every light about the vertical axis through the scene's centre, one turn per
    /// SECONDS_PER_TURN (default 10), so any scene shows moving light and caustics.
    #[arg(long, value_name = "SECONDS_PER_TURN", num_args = 0..=1, default_missing_value = "10",
          value_parser = parse_seconds_per_turn)]
    orbit_lights: Option<f32>,
    /// Count NaN, ±Inf and negative values in every HDR buffer on the GPU, every frame (the
    /// times then include the check); the last frames' counts are printed and in --json.
    #[arg(long)]
    check_values: bool,
}

pub fn bench(args: BenchArgs, device: Option<usize>) -> anyhow::Result<()> {
    for path in [args.json.as_ref(), args.figure.as_ref()]
        .into_iter()
        .flatten()
    {
        ispm::output::check_writable(path)?;
    }
    let scene = load_scene_from(
        args.scene.as_deref(),
        &args.scene_args,
        args.camera,
        args.orbit_lights,
    )?;
    let scene_name = args.scene.as_deref().unwrap_or("cornell-box");
    let knobs = Knobs {
        size: Some(args.size),
        shadow_resolution: Some(args.shadow_resolution),
        check_values: Some(args.check_values),
        density: Some(args.density),
        denoise: Some(args.denoise),
        schedule: Some(args.schedule),
        ..args.quality.knobs(None)
    };
    let gpu = gpu(device)?;
    let (width, height) = args.size;
    let settings = ispm::bench::BenchSettings {
        knobs,
        frames: args.frames,
        warmup: args.warmup,
        chunks: args.chunks,
        compare_effects: args.compare_effects,
        compare_density: args.compare_density,
        compare_subsample: args.compare_subsample,
    };
    let report = ispm::bench::run(&gpu, &scene, scene_name, &settings, |step| {
        log::info!("bench: {step}")
    })?;
    check_validation(&gpu)?;
    print!("{}", report.table());
    if let Some(path) = &args.json {
        ispm::output::write_atomically(path, |f| {
            serde_json::to_writer_pretty(f, &report)
                .with_context(|| format!("{}: cannot write JSON", path.display()))
        })?;
    }
    if let Some(path) = &args.figure {
        let title = format!("{scene_name}, {width}x{height}, overlapped schedule");
        let svg = ispm::bench::schedule_svg(&report.last_overlapped_spans, &title);
        ispm::output::write_atomically(path, |f| {
            use std::io::Write;
            f.write_all(svg.as_bytes())
                .with_context(|| format!("{}: cannot write SVG", path.display()))
        })?;
    }
    Ok(())
}
