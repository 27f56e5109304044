//! The `ispm` command line (DESIGN.md §7). Parsing and reporting only: the work is in the
//! library.

use anyhow::Context;
use clap::{Parser, Subcommand, ValueEnum};
use ispm::frame::{RenderSettings, Renderer, Schedule};
use ispm::gpu::{Gpu, GpuOptions};
use ispm::output::{write_exr, write_png, OutputFormat};
use ispm::passes::tonemap::Tonemap;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "ispm",
    version,
    about = "Real-time global illumination by Image Space Photon Mapping"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Vulkan physical device index (see `ispm info`); default: the best one.
    #[arg(long, global = true)]
    device: Option<usize>,
}

#[derive(Subcommand)]
enum Command {
    /// Render one frame headless to PNG (tonemapped) or EXR (linear HDR).
    Render(RenderArgs),
    /// Print the Vulkan devices, the driver, and the queues the renderer uses.
    Info,
    /// Print the effects plan of a scene: which passes, shader variants, lights and bounces a
    /// frame needs, one line per decision with its reason (no GPU needed).
    Plan(PlanArgs),
    /// Measure the frame per stage, the overlapped schedule against the serial one and the
    /// direct-only frame, side by side in one run.
    Bench(BenchArgs),
    /// Open a window and render the scene live (W A S D Q E fly, right button looks, Esc quits)
    ///
    /// Keys and mouse:
    ///   W / S      fly forward / back along the view
    ///   A / D      fly left / right
    ///   Q / E      fly down / up (the world's vertical)
    ///   right button held + mouse   look around
    ///   wheel      fly speed ×1.25 per notch (starts at a quarter of the scene's diagonal per s)
    ///   F          frame the scene: back away along the view until its bounds fit
    ///   C          the file's next camera (--camera N picks the first one shown)
    ///   Tab        show / hide the overlay (times, effects plan, settings, debug views)
    ///   P          screenshot (PNG) + its stats JSON, into --shots DIR (default: .)
    ///   T          Chrome trace of the next 30 frames, into --shots DIR
    ///   Esc        quit
    ///
    /// With --frames N the camera follows a scripted path instead (a swing about the point
    /// the start camera looks at, and a dolly towards it), frame k at a pose that depends on k
    /// alone: `ispm render --camera-path-frame N` renders the pose of the last frame.
    #[command(verbatim_doc_comment)]
    View(ViewArgs),
    /// Measure accuracy against time: render the scene over a grid of settings, time every
    /// stage and compare with a cached CPU reference; write results.csv, results.json and SVG
    /// plots (the error–time Pareto front) into --out. Resumable.
    Sweep(SweepArgs),
}

#[derive(clap::Args)]
struct SweepArgs {
    /// A .gltf/.glb file or a bundled scene name (default: the bundled cornell-box).
    scene: Option<String>,
    #[command(flatten)]
    scene_args: SceneArgs,
    /// Folder for results.csv, results.json and the plots (configurations already in its
    /// results.json are not measured again).
    #[arg(long)]
    out: PathBuf,
    /// Knobs and their values, `KNOB=V,V;KNOB=V` (photons, bounces, radius, subsample,
    /// caustic-share, upsample, accumulate, density, method), e.g.
    /// `photons=10k,40k;subsample=1,2`; knobs not named keep their defaults (docs/accuracy.md
    /// §5).
    #[arg(long, default_value = "")]
    grid: String,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "160x120", value_parser = parse_size)]
    size: (u32, u32),
    /// Timed frames per configuration (after one warm-up frame).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..))]
    frames: u32,
    /// Reference: path-tracer samples per pixel, or progressive photon mapping iterations.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..))]
    reference_passes: u32,
    /// Reference: photons per progressive photon mapping iteration.
    #[arg(long, default_value_t = 100_000)]
    reference_photons: usize,
    /// Reference: most bounces of a light path (default: until Russian roulette ends it, at
    /// most 256).
    #[arg(long, default_value_t = ispm::photon::trace::MAX_BOUNCES)]
    reference_bounces: u32,
    /// Where references are cached (default: $XDG_CACHE_HOME/ispm/references).
    #[arg(long, value_name = "DIR")]
    reference_cache: Option<PathBuf>,
    /// Render from the file's camera N (0-based, in node order; default: the first).
    #[arg(long, value_name = "N")]
    camera: Option<usize>,
}

#[derive(clap::Args)]
struct ViewArgs {
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
    #[arg(long, value_enum, default_value = "auto")]
    density: ispm::frame::Density,
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

#[derive(clap::Args)]
struct BenchArgs {
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
    #[arg(long, default_value_t = 1024)]
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
    #[arg(long, value_enum, default_value = "auto")]
    density: ispm::frame::Density,
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
    #[arg(long, value_enum, default_value = "auto")]
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

/// `--quality` and the knobs it sets, shared by `render`, `view` and `bench` (src/quality.rs).
#[derive(clap::Args)]
struct QualityArgs {
    /// Set photons, bounces, kernel radius and subsampling to a point measured on the
    /// error–time Pareto fronts of the bundled scenes (docs/accuracy.md §5); explicit flags
    /// override its values. `none`: no preset, the flags' own defaults. Default: `high` for
    /// `render --method ispm`, `interactive` for `view`, `none` otherwise.
    #[arg(long, value_enum)]
    quality: Option<ispm::quality::QualityFlag>,
    /// Photons emitted per frame, split over the lights by power (default: the --quality
    /// preset's; 100000 without one). A light view holds at most 2048x2048 texels: a light whose share
    /// asks for more emits fewer photons, and `render` says so.
    #[arg(long)]
    photons: Option<usize>,
    /// Estimate indirect light at 1/N resolution and upsample it (--upsample; N is clamped to
    /// the image size; 1: full resolution). Default: the --quality preset's; 1 without one.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    subsample: Option<u32>,
    /// Most scattering events per photon, and per path for the references (default: until
    /// Russian roulette ends the path, at most 256; a lower N cuts the light after N bounces).
    #[arg(long)]
    bounces: Option<u32>,
    /// Largest photon kernel radius in metres (default: from the scene size and photon count,
    /// scaled by the --quality preset's factor).
    #[arg(long)]
    radius: Option<f32>,
    /// At --subsample N > 1: `joint` bilateral upsampling against the full-resolution G-buffer,
    /// or plain `bilinear` (default joint).
    #[arg(long, value_enum)]
    upsample: Option<ispm::passes::upsample::Upsample>,
}

impl QualityArgs {
    /// The knobs for `scene`: explicit flags, else the preset (`--quality`, else the command's
    /// `default` preset), else the flags' own defaults.
    fn resolve(
        &self,
        scene: &ispm::scene::Scene,
        default: Option<ispm::quality::Quality>,
    ) -> anyhow::Result<ispm::quality::Knobs> {
        if let Some(r) = self.radius {
            anyhow::ensure!(
                r.is_finite() && r > 0.0,
                "--radius {r} must be a positive length"
            );
        }
        Ok(ispm::quality::resolve(
            self.quality
                .map_or(default, ispm::quality::QualityFlag::preset),
            ispm::quality::Explicit {
                photons: self.photons,
                bounces: self.bounces,
                radius: self.radius,
                subsample: self.subsample,
                upsample: self.upsample,
            },
            &scene.bounds(),
        ))
    }
}

/// How the scene file is read, shared by every command that loads one.
#[derive(clap::Args)]
struct SceneArgs {
    /// Render a scene with no light and no emissive surface as it is (unlit: only unlit
    /// materials show) instead of adding the default key light over the camera's shoulder.
    #[arg(long)]
    no_default_light: bool,
    /// KHR_materials_variants: show the material variant NAME instead of the default materials.
    #[arg(long, value_name = "NAME")]
    variant: Option<String>,
}

impl SceneArgs {
    fn options(&self) -> ispm::scene::load::LoadOptions {
        ispm::scene::load::LoadOptions {
            default_light: !self.no_default_light,
            variant: self.variant.clone(),
        }
    }
}

#[derive(clap::Args)]
struct PlanArgs {
    /// A .gltf/.glb file or a bundled scene name (default: the bundled cornell-box).
    scene: Option<String>,
    #[command(flatten)]
    scene_args: SceneArgs,
    /// Image size, WIDTHxHEIGHT (the view's aspect ratio).
    #[arg(long, default_value = "640x480", value_parser = parse_size)]
    size: (u32, u32),
    #[arg(long, value_enum, default_value = "ispm")]
    method: ispm::frame::Method,
    /// Photons emitted per frame, split over the active lights by power (default: what
    /// `render` uses, the `high` preset's for ISPM, else 100000).
    #[arg(long)]
    photons: Option<usize>,
    /// Most scattering events per photon (default: until Russian roulette ends the path, at
    /// most 256).
    #[arg(long, default_value_t = ispm::photon::trace::MAX_BOUNCES)]
    bounces: u32,
    /// Photon volumes at 1/N resolution (default: what `render` uses, the `high` preset's for
    /// ISPM, else 1).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    subsample: Option<u32>,
    /// `auto`: plan; `all`: every pass, variant, light and bounce (the unplanned frame).
    #[arg(long, value_enum, default_value = "auto")]
    effects: ispm::plan::Effects,
    /// The density estimator the plan lists (`auto`: what `render` picks on the device
    /// `--device` chooses, or on the first usable one).
    #[arg(long, value_enum, default_value = "auto")]
    density: ispm::frame::Density,
    /// GPU methods: levels of the edge-avoiding à-trous filter over the indirect light (taps up
    /// to ±2·(2^N − 1) pixels apart, on one surface), fewer as still frames accumulate and none
    /// from the 2^N-th on, so the mean converges as without it (0: the raw estimate;
    /// docs/accuracy.md, "The denoiser").
    #[arg(long, value_name = "N", default_value_t = ispm::passes::denoise::DEFAULT_LEVELS,
          value_parser = clap::value_parser!(u32).range(0..=ispm::passes::denoise::MAX_LEVELS as i64))]
    denoise: u32,
    /// Plan the view of the file's camera N (0-based, in node order; default: the first).
    #[arg(long, value_name = "N")]
    camera: Option<usize>,
    /// Orbit every light about the vertical axis through the scene's centre, one turn per
    /// SECONDS_PER_TURN (default 10), so any scene shows moving light and caustics.
    #[arg(long, value_name = "SECONDS_PER_TURN", num_args = 0..=1, default_missing_value = "10",
          value_parser = parse_seconds_per_turn)]
    orbit_lights: Option<f32>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Method {
    /// Image Space Photon Mapping on the GPU (direct + photon-mapped indirect light).
    Ispm,
    /// Shadow-mapped deferred direct light only (GPU).
    Direct,
    /// CPU reference: traditional photon mapping with a k-d tree gather, same kernel as ISPM.
    PhotonGather,
    /// CPU reference: unidirectional path tracing with next-event estimation.
    PathTrace,
    /// CPU reference: progressive photon mapping (consistent, for caustics).
    Progressive,
}

#[derive(clap::Args)]
struct RenderArgs {
    /// A .gltf/.glb file or a bundled scene name (default: the bundled cornell-box).
    scene: Option<String>,
    #[command(flatten)]
    scene_args: SceneArgs,
    /// Output image: .png (tonemapped sRGB) or .exr (linear HDR).
    #[arg(short, long, default_value = "out.png")]
    output: PathBuf,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "640x480", value_parser = parse_size)]
    size: (u32, u32),
    #[arg(long, value_enum, default_value = "ispm")]
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
    /// GPU methods: the density estimator: `volumes` (each photon's kernel rasterised as a
    /// billboard, the paper's), `tiled` (a per-tile gather in compute; the same sums) or `auto`
    /// (the faster on this device: tiled on a CPU implementation such as lavapipe, volumes on
    /// a GPU; `ispm info` says which).
    #[arg(long, value_enum, default_value = "auto")]
    density: ispm::frame::Density,
    /// GPU methods: levels of the edge-avoiding à-trous filter over the indirect light (taps up
    /// to ±2·(2^N − 1) pixels apart, on one surface), fewer as still frames accumulate and none
    /// from the 2^N-th on, so the mean converges as without it (0: the raw estimate;
    /// docs/accuracy.md, "The denoiser").
    #[arg(long, value_name = "N", default_value_t = ispm::passes::denoise::DEFAULT_LEVELS,
          value_parser = clap::value_parser!(u32).range(0..=ispm::passes::denoise::MAX_LEVELS as i64))]
    denoise: u32,
    /// GPU methods: `overlapped` traces the photons on the CPU while the GPU draws the eye
    /// G-buffer and direct light and keeps frames in flight (the paper's Figure 3); `auto` does
    /// the same except on a CPU device (lavapipe), whose passes run on the cores the trace
    /// would use, where the trace waits for them; `serial` runs every step strictly after the
    /// one before.
    #[arg(long, value_enum, default_value = "auto")]
    schedule: Schedule,
    /// Seed of every random choice.
    #[arg(long, default_value_t = 0)]
    seed: u32,
    /// GPU methods: `auto` skips the passes, shader variants, lights and bounces the scene
    /// does not need (`ispm plan` prints why); `all` runs everything (the unplanned frame).
    #[arg(long, value_enum, default_value = "auto")]
    effects: ispm::plan::Effects,
    /// Write the frame's statistics (the paper's Table 2 columns) as JSON.
    #[arg(long)]
    stats: Option<PathBuf>,
    /// Write a Chrome Trace Event JSON of every frame (GPU passes per queue, CPU work per
    /// thread, on one clock); open it in ui.perfetto.dev.
    #[arg(long)]
    trace: Option<PathBuf>,
    /// Display transform for PNG output.
    #[arg(long, value_enum, default_value = "pbr-neutral")]
    tonemap: Tonemap,
    /// Exposure in stops (radiance × 2^EV before tonemapping).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    exposure: f32,
    /// Shadow-map resolution per light view.
    #[arg(long, default_value_t = 1024)]
    shadow_resolution: u32,
    /// Smallest share (0 to 0.95) of each light's photons spent on its caustic views: windows
    /// of its views around the mirrors and glass it lights, at a higher texel density (0: none).
    #[arg(long, default_value_t = ispm::ispm::CAUSTIC_SHARE, value_parser = parse_share)]
    caustic_share: f32,
    /// Points sampled on the emissive surfaces per frame, each a shadow-mapped light that emits
    /// photons (new points every accumulated frame; 0: emitters are seen but light nothing).
    #[arg(long, value_name = "N", default_value_t = ispm::scene::emitters::DEFAULT_EMITTER_LIGHTS)]
    emitter_lights: u32,
    /// Render from the file's camera N (0-based, in node order; default: the first).
    #[arg(long, value_name = "N")]
    camera: Option<usize>,
    /// Render from the pose of frame K of `ispm view --frames`'s scripted camera path (which
    /// starts at the --camera one): the headless twin of the viewer's screenshot.
    #[arg(long, value_name = "K")]
    camera_path_frame: Option<u32>,
    /// Orbit every light about the vertical axis through the scene's centre, one turn per
    /// SECONDS_PER_TURN (default 10), so any scene shows moving light and caustics.
    #[arg(long, value_name = "SECONDS_PER_TURN", num_args = 0..=1, default_missing_value = "10",
          value_parser = parse_seconds_per_turn)]
    orbit_lights: Option<f32>,
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

fn parse_seconds_per_turn(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!(
            "{s:?} is not a positive number of seconds per turn (put the scene before \
             --orbit-lights)"
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

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("size {s:?} is not WIDTHxHEIGHT"))?;
    let parse = |v: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|_| format!("size {s:?} is not WIDTHxHEIGHT"))
    };
    let (w, h) = (parse(w)?, parse(h)?);
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!("size {s:?} must be between 1x1 and 16384x16384"));
    }
    Ok((w, h))
}

/// The scene of `arg` read as `scene_args` say, seen from its file's camera `camera`
/// (`--camera N`) if given, with its lights orbiting when `--orbit-lights` asks. Says on
/// stderr when the default light was added, or when `--no-default-light` leaves the scene
/// without light.
fn load_scene_from(
    arg: Option<&str>,
    scene_args: &SceneArgs,
    camera: Option<usize>,
    orbit_lights: Option<f32>,
) -> anyhow::Result<ispm::scene::Scene> {
    let mut scene = ispm::scene::bundled::resolve_with(arg, &scene_args.options())?;
    let name = arg.unwrap_or("cornell-box");
    if let Some(n) = camera {
        let count = scene.cameras.len();
        scene.camera = *scene.cameras.get(n).ok_or_else(|| match count {
            0 => anyhow::anyhow!("--camera {n}: {name} has no cameras"),
            1 => anyhow::anyhow!("--camera {n}: {name} has 1 camera (--camera 0)"),
            _ => anyhow::anyhow!(
                "--camera {n}: {name} has {count} cameras (--camera 0 to {})",
                count - 1
            ),
        })?;
        scene.aim_default_light();
    }
    if let Some(seconds) = orbit_lights {
        scene.orbit_lights(seconds).context("--orbit-lights")?;
    }
    if scene.default_light {
        eprintln!(
            "ispm: {name} has no lights; adding a default key light (--no-default-light turns \
             it off)"
        );
    } else if scene.needs_default_light() {
        eprintln!(
            "ispm: warning: {name} has no lights and --no-default-light keeps it so: nothing in \
             it is lit (only unlit materials show)"
        );
    }
    Ok(scene)
}

fn gpu(cli_device: Option<usize>) -> anyhow::Result<std::sync::Arc<Gpu>> {
    Gpu::new(&GpuOptions {
        device_index: cli_device,
        ..Default::default()
    })
    .context("cannot start Vulkan")
}

/// Fails when the validation layer reported anything (printing every message first).
fn check_validation(gpu: &Gpu) -> anyhow::Result<()> {
    let messages = gpu.validation_messages();
    if messages.is_empty() {
        return Ok(());
    }
    for m in &messages {
        eprintln!("validation: {m}");
    }
    anyhow::bail!(
        "the Vulkan validation layer reported {} message(s)",
        messages.len()
    )
}

fn view(args: ViewArgs, device: Option<usize>) -> anyhow::Result<()> {
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
    let knobs = args
        .quality
        .resolve(&scene, Some(ispm::quality::VIEW_DEFAULT))?;
    let (width, height) = args.size;
    let settings = ispm::viewer::ViewSettings {
        render: RenderSettings {
            photons: knobs.photons,
            bounces: knobs.bounces,
            radius: knobs.radius,
            width,
            height,
            subsample: knobs.subsample,
            upsample: knobs.upsample,
            accumulate: !args.no_accumulate,
            density: args.density,
            denoise: args.denoise,
            ..Default::default()
        },
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

fn bench(args: BenchArgs, device: Option<usize>) -> anyhow::Result<()> {
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
    let knobs = args.quality.resolve(&scene, None)?;
    let gpu = gpu(device)?;
    let (width, height) = args.size;
    let settings = ispm::bench::BenchSettings {
        render: RenderSettings {
            photons: knobs.photons,
            bounces: knobs.bounces,
            radius: knobs.radius,
            width,
            height,
            subsample: knobs.subsample,
            upsample: knobs.upsample,
            shadow_resolution: args.shadow_resolution.clamp(16, 8192),
            check_values: args.check_values,
            density: args.density,
            denoise: args.denoise,
            schedule: args.schedule,
            ..Default::default()
        },
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

fn sweep(args: SweepArgs, device: Option<usize>) -> anyhow::Result<()> {
    let grid = ispm::sweep::Grid::parse(&args.grid)?;
    anyhow::ensure!(
        !args.out.is_file(),
        "--out {}: a file, not a folder",
        args.out.display()
    );
    let scene = load_scene_from(args.scene.as_deref(), &args.scene_args, args.camera, None)?;
    let scene_name = args.scene.as_deref().unwrap_or("cornell-box");
    let gpu = gpu(device)?;
    let settings = ispm::sweep::SweepSettings {
        grid,
        width: args.size.0,
        height: args.size.1,
        frames: args.frames,
        reference: ispm::sweep::ReferenceSpec {
            passes: args.reference_passes,
            photons: args.reference_photons,
            bounces: args.reference_bounces,
        },
        reference_cache: args.reference_cache,
    };
    let report = ispm::sweep::run(&gpu, &scene, scene_name, &settings, &args.out)?;
    check_validation(&gpu)?;
    print!("{}", report.table());
    eprintln!(
        "{} configuration(s) measured, {} already in {}; reference {} ({})",
        report.measured,
        report.skipped,
        args.out.join("results.json").display(),
        report.reference_path.display(),
        if report.reference_rendered {
            "rendered"
        } else {
            "cached"
        }
    );
    Ok(())
}

fn render(args: RenderArgs, device: Option<usize>) -> anyhow::Result<()> {
    let format = OutputFormat::from_path(&args.output)?;
    // Outputs that cannot be written fail before any work, so none is left half done.
    for path in [Some(&args.output), args.stats.as_ref(), args.trace.as_ref()]
        .into_iter()
        .flatten()
    {
        ispm::output::check_writable(path)?;
    }
    if let Some(r) = args.quality.radius {
        anyhow::ensure!(
            r.is_finite() && r > 0.0,
            "--radius {r} must be a positive length"
        );
    }
    let scene = load_scene_from(
        args.scene.as_deref(),
        &args.scene_args,
        args.camera,
        args.orbit_lights,
    )?;
    // ISPM starts from a preset; direct light and the CPU references from the flags' own
    // defaults.
    let default = (args.method == Method::Ispm).then_some(ispm::quality::RENDER_DEFAULT);
    let knobs = args.quality.resolve(&scene, default)?;
    // The viewer's scripted path starts from the scene as loaded.
    let path_pose = args
        .camera_path_frame
        .map(|k| ispm::camera_control::scripted_pose(&scene.camera, &scene.bounds(), k));
    let mut scene = scene.posed(args.time);
    if let Some(camera) = path_pose {
        scene.camera = camera;
    }
    let (width, height) = args.size;
    let reference = match args.method {
        Method::PhotonGather => Some(ispm::reference::Method::PhotonGather),
        Method::PathTrace => Some(ispm::reference::Method::PathTrace),
        Method::Progressive => Some(ispm::reference::Method::Progressive),
        Method::Ispm | Method::Direct => None,
    };
    if let Some(method) = reference {
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
        return render_reference(&args, &knobs, &scene, method, format);
    }
    if let Some(view) = args.debug_view {
        anyhow::ensure!(
            format == OutputFormat::Png || view == ispm::passes::debug_view::DebugView::DirectOnly,
            "{}: --debug-view {view:?} is an 8-bit false-colour image: write a .png",
            args.output.display()
        );
    }
    let gpu = gpu(device)?;
    let settings = RenderSettings {
        method: if args.method == Method::Direct {
            ispm::frame::Method::Direct
        } else {
            ispm::frame::Method::Ispm
        },
        photons: knobs.photons,
        bounces: knobs.bounces,
        radius: knobs.radius,
        seed: args.seed,
        width,
        height,
        shadow_resolution: args.shadow_resolution.clamp(16, 8192),
        tonemap: args.tonemap,
        exposure_ev: args.exposure,
        subsample: knobs.subsample,
        upsample: knobs.upsample,
        schedule: args.schedule,
        density: args.density,
        denoise: args.denoise,
        effects: args.effects,
        caustic_share: args.caustic_share,
        emitter_lights: args.emitter_lights.min(64),
        check_values: args.check_values,
        accumulate: !args.no_accumulate,
        ..Default::default()
    };
    if args.trace.is_some() {
        ispm::timing::start_capture();
    }
    let (frame, triangles) = {
        let mut renderer = Renderer::new(&gpu, &scene, settings)?;
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
                    let to_finish = (ispm::frame::FRAMES_IN_FLIGHT + 1) as f64 * period;
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
        let json = ispm::stats::frame_json(
            &scene,
            &frame,
            triangles,
            knobs.bounces,
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
        let side = ispm::ispm::MAX_RESOLUTION;
        eprintln!(
            "note: the photon budget of light {} asks for light views past the largest \
             ({side}x{side} texels): the frame emits {} photons of the {} asked",
            names.join(", light "),
            frame.stats.emitted_photons,
            knobs.photons
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

fn render_reference(
    args: &RenderArgs,
    knobs: &ispm::quality::Knobs,
    scene: &ispm::scene::Scene,
    method: ispm::reference::Method,
    format: OutputFormat,
) -> anyhow::Result<()> {
    anyhow::ensure!(
        format == OutputFormat::Exr,
        "{}: the CPU references write linear EXR (use a .exr file name)",
        args.output.display()
    );
    let settings = ispm::reference::RefSettings {
        width: args.size.0,
        height: args.size.1,
        spp: args.spp.max(1),
        photons: knobs.photons,
        bounces: knobs.bounces,
        iterations: args.frames.unwrap_or(16),
        radius: knobs.radius,
        seed: args.seed,
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

fn plan(args: PlanArgs, device: Option<usize>) -> anyhow::Result<()> {
    let scene = load_scene_from(
        args.scene.as_deref(),
        &args.scene_args,
        args.camera,
        args.orbit_lights,
    )?;
    // The knobs `render` would use (its default preset for ISPM).
    let preset =
        (args.method == ispm::frame::Method::Ispm).then(|| ispm::quality::RENDER_DEFAULT.preset());
    let settings = RenderSettings {
        method: args.method,
        photons: args
            .photons
            .or(preset.map(|p| p.photons))
            .unwrap_or(ispm::quality::DEFAULT_PHOTONS),
        bounces: args.bounces,
        width: args.size.0,
        height: args.size.1,
        subsample: args.subsample.or(preset.map(|p| p.subsample)).unwrap_or(1),
        effects: args.effects,
        density: args.density.resolve_for(device),
        denoise: args.denoise,
        ..Default::default()
    };
    let plan = ispm::plan::EffectsPlan::analyse(&scene, &settings, &scene.camera);
    print!("{plan}");
    let name = args.scene.as_deref().unwrap_or("cornell-box");
    let default_light = if scene.default_light {
        format!(
            "yes — {name} has no lights and no emissive surfaces: light 0 '{}' is a spot over \
             the camera's shoulder (--no-default-light turns it off)",
            scene.lights[0].name
        )
    } else if !scene.lights.is_empty() {
        format!("no — the scene has {} light(s)", scene.lights.len())
    } else if scene.has_emitter() {
        "no — its emissive surfaces light it".to_string()
    } else {
        "no — --no-default-light: nothing in the scene is lit".to_string()
    };
    println!("default light: {default_light}");
    Ok(())
}

fn info(device: Option<usize>) -> anyhow::Result<()> {
    let devices = ispm::gpu::list_devices().context("cannot start Vulkan")?;
    println!("Vulkan devices:");
    for (i, (p, ok)) in devices.iter().enumerate() {
        let v = p.api_version;
        println!(
            "  [{i}] {} ({:?}), Vulkan {}.{}.{}, driver {} {}{}",
            p.name,
            p.device_type,
            ispm::gpu::vk::api_version_major(v),
            ispm::gpu::vk::api_version_minor(v),
            ispm::gpu::vk::api_version_patch(v),
            p.driver_name,
            p.driver_info,
            match ok {
                Ok(()) => String::new(),
                Err(why) => format!(" — unusable: {why}"),
            }
        );
        for (f, q) in p.families.iter().enumerate() {
            println!(
                "      queue family {f}: {} queue(s), {:?}, timestamp bits {}",
                q.queue_count, q.queue_flags, q.timestamp_valid_bits
            );
        }
    }
    let gpu = gpu(device)?;
    let p = &gpu.properties;
    println!("Using: {} ({})", p.name, p.driver_name);
    for role in ispm::gpu::QueueRole::ALL {
        let q = gpu.queue(role);
        println!(
            "  {:>8}: queue family {} (queue {} of the renderer's {})",
            role.name(),
            q.family,
            gpu.queue_index(role),
            gpu.queue_list().len()
        );
    }
    println!(
        "  timestamps: {} ns/tick, on the host clock by {}",
        p.timestamp_period,
        gpu.clock_source()
    );
    let density = ispm::frame::Density::Auto.resolve_for_device(p);
    println!(
        "  --density auto: {density:?}, compute subgroup ops for the tiled gather: {} (measured \
         on lavapipe and an NVIDIA H100, docs/performance.md \"Density estimators\")",
        if p.compute_subgroup_gather {
            "yes"
        } else {
            "no"
        }
    );
    println!(
        "  validation: {}",
        if gpu.validation {
            "on"
        } else {
            "off (ISPM_VALIDATION=1 turns it on)"
        }
    );
    check_validation(&gpu)
}

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    // A bug must still end in one clear line, not a backtrace dump.
    std::panic::set_hook(Box::new(|info| {
        eprintln!("ispm: internal error: {info}");
    }));
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => render(args, cli.device),
        Command::Info => info(cli.device),
        Command::Plan(args) => plan(args, cli.device),
        Command::Bench(args) => bench(args, cli.device),
        Command::View(args) => view(args, cli.device),
        Command::Sweep(args) => sweep(args, cli.device),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("ispm: {e:#}");
            ExitCode::FAILURE
        }
    }
}
