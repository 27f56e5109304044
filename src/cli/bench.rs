//! `ispm bench`: the frame's cost per stage, schedules side by side (`ispm::tools::bench`).

use super::{check_validation, gpu, parse_size, EstimateArgs, OrbitArgs, QualityArgs, SceneArgs};
use anyhow::Context;
use ispm::config::settings::{Knobs, Schedule, DEFAULT_SHADOW_RESOLUTION};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct BenchArgs {
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
    #[command(flatten)]
    estimate: EstimateArgs,
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
    /// times cheaper its radiance estimate (density, support, denoise and upsample passes) and
    /// frame are.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=64))]
    compare_subsample: Option<u32>,
    /// Also measure the frame as the effects plan makes it (`--effects auto`) against the
    /// overlapped frame, which runs every pass and variant (`--effects all`), in the same
    /// alternating chunks.
    #[arg(long)]
    compare_effects: bool,
    #[command(flatten)]
    orbit: OrbitArgs,
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
    let scene = args.scene_args.load(&args.orbit)?;
    let scene_name = args.scene_args.name();
    let knobs = Knobs {
        size: Some(args.size),
        shadow_resolution: Some(args.shadow_resolution),
        check_values: Some(args.check_values),
        density: Some(args.estimate.density),
        denoise: Some(args.estimate.denoise),
        schedule: Some(args.schedule),
        ..args.quality.knobs(None)
    };
    let gpu = gpu(device)?;
    let (width, height) = args.size;
    let settings = ispm::tools::bench::BenchSettings {
        knobs,
        frames: args.frames,
        warmup: args.warmup,
        chunks: args.chunks,
        compare_effects: args.compare_effects,
        compare_density: args.compare_density,
        compare_subsample: args.compare_subsample,
    };
    let report = ispm::tools::bench::run(&gpu, &scene, scene_name, &settings, |step| {
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
        let svg = ispm::tools::bench::schedule_svg(&report.last_overlapped_spans, &title);
        ispm::output::write_atomically(path, |f| {
            use std::io::Write;
            f.write_all(svg.as_bytes())
                .with_context(|| format!("{}: cannot write SVG", path.display()))
        })?;
    }
    Ok(())
}
