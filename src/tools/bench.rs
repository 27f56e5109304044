//! `ispm bench`: the frame's cost, per stage and as a whole, and what the overlapped schedule
//! buys, measured side by side in one run.
//!
//! Three renderers of the same view run in alternating chunks of frames, so that a noisy
//! machine slows them alike: the overlapped ISPM frame (the `--schedule` asked for: `auto`,
//! whose trace waits for box B on a CPU device, or `overlapped`), the serial ISPM frame (every
//! step waits for the one before) and the direct-only frame (the paper's Table 2, column 19 vs 20). Each
//! chunk is one trace capture (`timing`); a chunk's frame period is its wall time (submitting
//! its frames and waiting for the last) over its frame count, and the figures are medians over
//! chunks. Per stage the spans of every frame give the median and the 10th–90th percentile.
//! An animated scene (glTF animations, `--orbit-lights`) advances by
//! [`FRAME_STEP_SECONDS`] per frame of each configuration, posed (`Renderer::set_pose`) before
//! each frame inside the measured time.
//!
//! The overlap figures:
//! - `overlap = frame period ÷ max(CPU stage, GPU stage)`, with the CPU stage the CPU photon
//!   trace and the GPU stage the sum of the frame's GPU passes: 1 when the slower unit never
//!   waits for the other, (CPU + GPU)/max when nothing overlaps;
//! - `speed-up = serial period ÷ overlapped period`.
//!
//! These three render every pass and shader variant and trace every frame
//! (`Effects::All`). With [`BenchSettings::compare_effects`] (`--compare-effects`) a fourth
//! renderer, the overlapped frame as the effects plan makes it (`Effects::Auto`:
//! passes, lobes, lights and bounces the scene does not need skipped, and a static scene's
//! photon map reused), joins the alternation, and `effects_speedup` = all ÷ planned frame
//! period. Every configuration's last frame reports the passes it ran and skipped and the shader
//! variants compiled out (the plan's lobes, the translucent pass's convex shortcut), with the
//! reasons (`FrameStats`).
//!
//! `--compare-density` adds the overlapped frame with the other density estimator, and
//! `--compare-subsample N` the overlapped frame with the indirect light estimated at 1/N
//! resolution ([`SubsampleSpeedup`]), each in the same alternation.

use crate::config::settings::SkippedPass;
use crate::config::settings::{Density, Effects, Knobs, Method, RenderSettings, Schedule};
use crate::gpu::Gpu;
use crate::render::frame::Renderer;
use crate::render::stats::ReusedLight;
use crate::scene::{Scene, FRAME_STEP_SECONDS};
use crate::timing::pass_id::PassId;
use crate::timing::{self, Span};
use serde::Serialize;
use std::collections::BTreeMap;
use std::sync::Arc;

mod subsample;
pub use subsample::{EstimatePasses, SubsampleSpeedup};

/// What to measure.
#[derive(Clone, Debug)]
pub struct BenchSettings {
    /// The knobs of the overlapped frame; every configuration is made of them
    /// ([`RenderSettings::from_knobs`]) with its method, schedule, effects, density and
    /// subsampling.
    pub knobs: Knobs,
    /// Measured frames per configuration.
    pub frames: u32,
    /// Frames per configuration before measuring.
    pub warmup: u32,
    /// Chunks the measured frames are split into (alternating configurations).
    pub chunks: u32,
    /// Also measure the planned frame (`Effects::Auto`) against the overlapped one, which
    /// runs everything (`Effects::All`).
    pub compare_effects: bool,
    /// Also measure the overlapped frame with the other density estimator (`--density`).
    pub compare_density: bool,
    /// Also measure the overlapped frame with the indirect light estimated at 1/N resolution
    /// (`--compare-subsample N`), against the overlapped one at the knobs' subsampling.
    pub compare_subsample: Option<u32>,
}

/// Median and spread of one stage, in milliseconds.
#[derive(Clone, Debug, Serialize)]
pub struct StageTime {
    pub median: f64,
    pub p10: f64,
    pub p90: f64,
    /// Frames it ran in.
    pub frames: usize,
}

/// One configuration's figures.
#[derive(Clone, Debug, Serialize)]
pub struct ConfigResult {
    pub name: String,
    /// Median over chunks of wall time ÷ frames.
    pub frame_ms: f64,
    /// Every chunk's frame period.
    pub chunk_frame_ms: Vec<f64>,
    /// GPU passes (`gpu.NAME`) and CPU steps (`cpu.NAME`).
    pub stages: BTreeMap<String, StageTime>,
    /// Median per frame of the GPU passes' sum.
    pub gpu_ms: f64,
    /// Median per frame of the CPU photon trace.
    pub cpu_ms: f64,
    /// The subsample factor its frames estimated the indirect light at.
    pub subsample: u32,
    /// The passes the last measured frame ran (`FrameStats::passes_run`).
    pub passes_run: Vec<String>,
    /// The passes it skipped, with the effects plan's reasons.
    pub passes_skipped: Vec<SkippedPass>,
    /// The über-BSDF lobes compiled out of its shaders and CPU trace, and the translucent
    /// pass's convex shortcut where it is, with the reasons (`FrameStats::variants_skipped`).
    pub variants_skipped: Vec<SkippedPass>,
    /// The lights whose photons the last measured frame traced, and those it kept.
    pub lights_retraced: Vec<usize>,
    pub lights_reused: Vec<ReusedLight>,
    /// The last measured frame's count of bad values (`--check-values` only).
    pub value_check: Option<crate::passes::value_check::ValueCheck>,
}

/// The whole benchmark.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    pub scene: String,
    pub device: String,
    pub width: u32,
    pub height: u32,
    pub photons: usize,
    pub frames: u32,
    pub overlapped: ConfigResult,
    pub serial: ConfigResult,
    pub direct_only: ConfigResult,
    /// The overlapped frame as the effects plan makes it (`--compare-effects` only).
    pub planned: Option<ConfigResult>,
    /// Overlapped (`Effects::All`) frame period ÷ planned frame period (`--compare-effects`).
    pub effects_speedup: Option<f64>,
    /// The density estimator of the overlapped, serial and planned frames (`--density`,
    /// resolved for the device).
    pub density: Density,
    /// The overlapped frame with the other estimator (`--compare-density` only).
    pub other_density: Option<ConfigResult>,
    /// Its frame period ÷ the overlapped frame's (`--compare-density`): how much slower the
    /// other estimator's frame is.
    pub density_speedup: Option<f64>,
    /// The overlapped frame with the estimate at another subsample factor
    /// (`--compare-subsample` only).
    pub other_subsample: Option<ConfigResult>,
    /// What subsampling buys (`--compare-subsample` only).
    pub subsample_speedup: Option<SubsampleSpeedup>,
    /// Overlapped frame period ÷ max(CPU stage, GPU stage).
    pub overlap: f64,
    /// Serial frame period ÷ overlapped frame period.
    pub speedup: f64,
    /// The last overlapped chunk's spans (for the schedule figure).
    #[serde(skip)]
    pub last_overlapped_spans: Vec<Span>,
}

impl ConfigResult {
    /// The median ms per frame of stage `pass`, if it ran.
    pub fn median(&self, pass: PassId) -> Option<f64> {
        self.stages.get(&pass.stage_key()).map(|t| t.median)
    }
}

struct Config {
    name: &'static str,
    renderer: Renderer,
    /// Frames rendered so far (the animation's clock).
    frames: u64,
    chunk_ms: Vec<f64>,
    spans: Vec<Span>,
    last_chunk: Vec<Span>,
    /// The last measured frame's stats.
    last_stats: crate::render::stats::FrameStats,
}

/// The value at quantile `q` (0..=1) of `values`, interpolated linearly between the closest
/// ranks (the median of an even count is the mean of the middle two).
pub fn quantile(values: &[f64], q: f64) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let pos = (v.len() - 1) as f64 * q.clamp(0.0, 1.0);
    let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
    v[lo] + (v[hi] - v[lo]) * (pos - lo as f64)
}

/// Per-frame totals of each stage: `gpu.NAME` sums a frame's GPU passes of that name,
/// `cpu.NAME` its CPU spans of that name, over the spans `keep` selects.
fn per_frame(spans: &[Span], keep: impl Fn(&Span) -> bool) -> BTreeMap<String, Vec<f64>> {
    let mut totals: BTreeMap<(String, u64), f64> = BTreeMap::new();
    for s in spans.iter().filter(|s| keep(s)) {
        let Some(frame) = s.frame else { continue };
        let key = if s.is_gpu() {
            format!("gpu.{}", s.name)
        } else {
            format!("cpu.{}", s.name)
        };
        *totals.entry((key, frame)).or_default() += s.ms();
    }
    let mut out: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for ((key, _), ms) in totals {
        out.entry(key).or_default().push(ms);
    }
    out
}

/// Median and spread over frames of every stage of `spans` that `keep` selects (keys as
/// [`ConfigResult::stages`]).
pub fn stage_times(spans: &[Span], keep: impl Fn(&Span) -> bool) -> BTreeMap<String, StageTime> {
    per_frame(spans, keep)
        .into_iter()
        .map(|(name, v)| {
            let t = StageTime {
                median: quantile(&v, 0.5),
                p10: quantile(&v, 0.1),
                p90: quantile(&v, 0.9),
                frames: v.len(),
            };
            (name, t)
        })
        .collect()
}

/// The GPU stage per frame: the busiest queue's sum of outermost passes (queues run side by
/// side, so their times do not add up).
pub fn gpu_per_frame(spans: &[Span]) -> Vec<f64> {
    let mut totals: BTreeMap<(u64, String), f64> = BTreeMap::new();
    for s in spans.iter().filter(|s| s.is_gpu() && s.depth == 0) {
        if let (Some(f), crate::timing::Track::Gpu { queue, .. }) = (s.frame, &s.track) {
            *totals.entry((f, queue.to_string())).or_default() += s.ms();
        }
    }
    let mut per_frame: BTreeMap<u64, f64> = BTreeMap::new();
    for ((f, _), ms) in totals {
        let busiest = per_frame.entry(f).or_default();
        *busiest = busiest.max(ms);
    }
    per_frame.into_values().collect()
}

fn result(config: &Config) -> ConfigResult {
    let stages = stage_times(&config.spans, |_| true);
    let cpu_ms = stages
        .get(&PassId::CpuTrace.stage_key())
        .map_or(0.0, |t| t.median);
    ConfigResult {
        name: config.name.to_string(),
        frame_ms: quantile(&config.chunk_ms, 0.5),
        chunk_frame_ms: config.chunk_ms.clone(),
        stages,
        gpu_ms: quantile(&gpu_per_frame(&config.spans), 0.5),
        cpu_ms,
        subsample: config.last_stats.subsample,
        passes_run: config.last_stats.passes_run.clone(),
        passes_skipped: config.last_stats.passes_skipped.clone(),
        variants_skipped: config.last_stats.variants_skipped.clone(),
        lights_retraced: config.last_stats.lights_retraced.clone(),
        lights_reused: config.last_stats.lights_reused.clone(),
        value_check: config.last_stats.value_check.clone(),
    }
}

/// Runs `frames` frames of `config`'s renderer in one capture (posing `scene` before each
/// when it is animated); returns the wall time per frame and the spans (frame indices made
/// unique across chunks by the renderer's own counter), and keeps the last frame's stats.
fn chunk(config: &mut Config, scene: &Scene, frames: u32) -> anyhow::Result<(f64, Vec<Span>)> {
    let (ms, spans, stats) = timed_frames(&mut config.renderer, scene, config.frames, frames)?;
    config.frames += u64::from(frames);
    config.last_stats = stats;
    Ok((ms, spans))
}

/// Runs `frames` frames of `renderer` in one timing capture and waits for the last; an
/// animated `scene` is posed before each frame at its clock (`first` + k frames). Returns the
/// wall time per frame (the frame period), the captured spans and the last frame's stats.
pub fn timed_frames(
    renderer: &mut Renderer,
    scene: &Scene,
    first: u64,
    frames: u32,
) -> anyhow::Result<(f64, Vec<Span>, crate::render::stats::FrameStats)> {
    timing::start_capture();
    let start = timing::now_ns();
    let run = (|| {
        for k in 0..u64::from(frames) {
            if scene.is_animated() {
                let t = (first + k) as f32 * FRAME_STEP_SECONDS;
                renderer.set_pose(&scene.pose_at(t))?;
            }
            renderer.submit_frame()?;
        }
        renderer.drain()
    })();
    let wall = timing::now_ns().saturating_sub(start) as f64 * 1e-6;
    let capture = timing::finish_capture();
    let stats = run?.1;
    Ok((wall / f64::from(frames.max(1)), capture.spans, stats))
}

/// Runs the benchmark (module docs).
pub fn run(
    gpu: &Arc<Gpu>,
    scene: &Scene,
    scene_name: &str,
    settings: &BenchSettings,
    mut progress: impl FnMut(&str),
) -> anyhow::Result<BenchReport> {
    let bounds = scene.bounds();
    let base = RenderSettings::from_knobs(&settings.knobs, &bounds)?;
    let density = base.density.resolve_for_device(&gpu.properties);
    let make_with = |name: &'static str,
                     (method, schedule, effects): (Method, Schedule, Effects),
                     density: Density,
                     subsample: u32| {
        let knobs = Knobs {
            method: Some(method),
            schedule: Some(schedule),
            density: Some(density),
            subsample: Some(subsample),
            // `All`: every frame traces (a planned frame of a static scene reuses its photon
            // map) and runs every pass and variant.
            effects: Some(effects),
            ..settings.knobs.clone()
        };
        let render = RenderSettings::from_knobs(&knobs, &bounds)?;
        Ok::<_, anyhow::Error>(Config {
            name,
            renderer: Renderer::new(gpu, scene, render)?,
            frames: 0,
            chunk_ms: Vec::new(),
            spans: Vec::new(),
            last_chunk: Vec::new(),
            last_stats: Default::default(),
        })
    };
    let make = |name: &'static str, method: Method, schedule: Schedule, effects: Effects| {
        make_with(name, (method, schedule, effects), density, base.subsample)
    };
    // The frame measured against the serial one: the schedule asked for (`--schedule`: the
    // default `auto`, or `overlapped` to run the trace beside box B on a CPU device too).
    let overlapped = match base.schedule {
        Schedule::Serial => Schedule::Auto,
        other => other,
    };
    let mut configs = vec![
        make("overlapped", Method::Ispm, overlapped, Effects::All)?,
        make("serial", Method::Ispm, Schedule::Serial, Effects::All)?,
        make("direct only", Method::Direct, overlapped, Effects::All)?,
    ];
    if settings.compare_effects {
        // `Renderer::new` logs its plan at info level, as for every configuration.
        configs.push(make("planned", Method::Ispm, overlapped, Effects::Auto)?);
    }
    let compare_density = settings.compare_density
        && (density == Density::Tiled || gpu.properties.compute_subgroup_gather);
    if settings.compare_density && !compare_density {
        progress("--compare-density: this device lacks the tiled gather's subgroup operations");
    }
    if compare_density {
        let (name, other) = match density {
            Density::Tiled => ("volumes", Density::Volumes),
            _ => ("tiled", Density::Tiled),
        };
        let frame = (Method::Ispm, overlapped, Effects::All);
        configs.push(make_with(name, frame, other, base.subsample)?);
    }
    if let Some(factor) = settings.compare_subsample {
        if factor == base.subsample_factor() {
            progress(&format!(
                "--compare-subsample {factor}: the same factor as the overlapped frame's"
            ));
        }
        let frame = (Method::Ispm, overlapped, Effects::All);
        configs.push(make_with("subsampled", frame, density, factor)?);
    }
    for c in &mut configs {
        progress(&format!("warm-up: {}", c.name));
        chunk(c, scene, settings.warmup.max(1))?;
    }
    let chunks = settings.chunks.clamp(1, settings.frames.max(1));
    for k in 0..chunks {
        // Spread the frames over the chunks as evenly as integers allow.
        let frames = u64::from(settings.frames);
        let n = (frames * u64::from(k + 1) / u64::from(chunks)
            - frames * u64::from(k) / u64::from(chunks)) as u32;
        for c in &mut configs {
            progress(&format!("chunk {}/{chunks}: {}", k + 1, c.name));
            let (ms, spans) = chunk(c, scene, n.max(1))?;
            c.chunk_ms.push(ms);
            c.last_chunk = spans.clone();
            c.spans.extend(spans);
        }
    }
    let planned = settings.compare_effects.then(|| result(&configs[3]));
    let other_subsample = settings
        .compare_subsample
        .map(|_| result(&configs.pop().expect("the subsampled configuration")));
    let other_density =
        compare_density.then(|| result(configs.last().expect("the other density's configuration")));
    let (o, s, d) = (
        result(&configs[0]),
        result(&configs[1]),
        result(&configs[2]),
    );
    let subsample_speedup = other_subsample
        .as_ref()
        .map(|c| SubsampleSpeedup::new(&o, o.subsample.max(1), c, c.subsample));
    let bound = o.cpu_ms.max(o.gpu_ms);
    let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { 0.0 };
    Ok(BenchReport {
        scene: scene_name.to_string(),
        device: gpu.properties.name.clone(),
        width: base.width,
        height: base.height,
        photons: base.photons,
        frames: settings.frames,
        overlap: if bound > 0.0 { o.frame_ms / bound } else { 0.0 },
        speedup: ratio(s.frame_ms, o.frame_ms),
        effects_speedup: planned.as_ref().map(|p| ratio(o.frame_ms, p.frame_ms)),
        planned,
        density,
        density_speedup: other_density
            .as_ref()
            .map(|c| ratio(c.frame_ms, o.frame_ms)),
        other_density,
        other_subsample,
        subsample_speedup,
        overlapped: o,
        serial: s,
        direct_only: d,
        last_overlapped_spans: std::mem::take(&mut configs[0].last_chunk),
    })
}

impl BenchReport {
    /// The human-readable table `ispm bench` prints.
    pub fn table(&self) -> String {
        let mut out = format!(
            "{} at {}x{}, {} photons, {} frames per configuration, on {}\n\n",
            self.scene, self.width, self.height, self.photons, self.frames, self.device
        );
        out += &format!(
            "{:<26} {:>12} {:>22}\n",
            "stage (overlapped)", "median ms", "p10 – p90 ms"
        );
        for (name, t) in &self.overlapped.stages {
            out += &format!(
                "{:<26} {:>12.3} {:>10.3} – {:<10.3}\n",
                name, t.median, t.p10, t.p90
            );
        }
        out += &format!(
            "\nframe period: overlapped {:.2} ms, serial {:.2} ms, direct only {:.2} ms\n",
            self.overlapped.frame_ms, self.serial.frame_ms, self.direct_only.frame_ms
        );
        out += &format!(
            "CPU stage (trace) {:.2} ms, GPU stage (passes) {:.2} ms\n",
            self.overlapped.cpu_ms, self.overlapped.gpu_ms
        );
        out += &format!(
            "overlap = frame ÷ max(CPU, GPU) = {:.3}; serial ÷ overlapped = {:.3}\n",
            self.overlap, self.speedup
        );
        let configs = [&self.overlapped, &self.serial, &self.direct_only]
            .into_iter()
            .chain(&self.planned)
            .chain(&self.other_density)
            .chain(&self.other_subsample);
        for c in configs {
            if let Some(check) = &c.value_check {
                let values: u64 = check.per_buffer.iter().map(|b| b.values).sum();
                out += &format!(
                    "value check ({}): {} bad of {values} values in the last frame\n",
                    c.name,
                    check.total_bad()
                );
            }
        }
        if let (Some(planned), Some(speedup)) = (&self.planned, self.effects_speedup) {
            out += &format!(
                "\neffects: planned {:.2} ms against all {:.2} ms (overlapped); all ÷ planned = \
                 {speedup:.3}\n",
                planned.frame_ms, self.overlapped.frame_ms
            );
            for p in &planned.passes_skipped {
                out += &format!("  skipped {}: {}\n", p.name, p.reason);
            }
            for v in &planned.variants_skipped {
                out += &format!("  compiled out {}: {}\n", v.name, v.reason);
            }
        }
        if let (Some(other), Some(speedup)) = (&self.other_density, self.density_speedup) {
            let pass = |c: &ConfigResult| {
                [PassId::PhotonTiles, PassId::PhotonVolumes]
                    .into_iter()
                    .find_map(|p| c.median(p).map(|ms| (p.stage_key(), ms)))
                    .unwrap_or((PassId::PhotonVolumes.stage_key(), 0.0))
            };
            let (a, b) = (pass(&self.overlapped), pass(other));
            out += &format!(
                "\ndensity: {:?} frame {:.2} ms ({} {:.2} ms), {} frame {:.2} ms ({} {:.2} ms); \
                 {} ÷ {:?} frame = {speedup:.3}, estimate {:.3}\n",
                self.density,
                self.overlapped.frame_ms,
                a.0,
                a.1,
                other.name,
                other.frame_ms,
                b.0,
                b.1,
                other.name,
                self.density,
                if a.1 > 0.0 { b.1 / a.1 } else { 0.0 },
            );
        }
        if let Some(s) = &self.subsample_speedup {
            out += &s.line();
        }
        out
    }
}

/// An SVG picture of `spans` in the manner of the paper's Figure 3: one row per track (GPU
/// queues first, then the CPU threads), coloured by frame: the outermost GPU passes, and on the
/// CPU the steps inside each `frame` span (the trace, the waits) and the trace workers' chunks.
pub fn schedule_svg(spans: &[Span], title: &str) -> String {
    use crate::timing::Track;
    let shown = |s: &Span| {
        if s.is_gpu() {
            s.depth == 0
        } else {
            s.name != "frame" && s.depth <= 1
        }
    };
    let outer: Vec<&Span> = spans.iter().filter(|s| shown(s)).collect();
    let (Some(t0), Some(t1)) = (
        outer.iter().map(|s| s.begin_ns).min(),
        outer.iter().map(|s| s.end_ns).max(),
    ) else {
        return String::new();
    };
    let mut tracks: Vec<(bool, String)> = Vec::new();
    let track_name = |s: &Span| match &s.track {
        Track::Gpu { queue, role } => (false, format!("GPU queue {queue} ({})", role.name())),
        Track::Cpu { name, .. } => (true, format!("CPU {name}")),
    };
    for s in &outer {
        let t = track_name(s);
        if !tracks.contains(&t) {
            tracks.push(t);
        }
    }
    tracks.sort();
    let (left, width, row) = (190.0, 900.0, 34.0);
    let height = 50.0 + row * tracks.len() as f64 + 20.0;
    let x = |ns: u64| left + (ns - t0) as f64 / (t1 - t0).max(1) as f64 * width;
    let colours = ["#4e79a7", "#f28e2b", "#59a14f", "#e15759", "#b07aa1"];
    let mut svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{height}\" \
         font-family=\"sans-serif\" font-size=\"11\">\n\
         <rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n\
         <text x=\"10\" y=\"20\" font-size=\"14\">{title} — {:.1} ms</text>\n",
        left + width + 20.0,
        (t1 - t0) as f64 * 1e-6
    );
    for (i, (_, name)) in tracks.iter().enumerate() {
        let y = 40.0 + row * i as f64;
        svg += &format!(
            "<text x=\"10\" y=\"{:.1}\">{name}</text>\n<line x1=\"{left}\" x2=\"{}\" y1=\"{:.1}\" \
             y2=\"{:.1}\" stroke=\"#ddd\"/>\n",
            y + 18.0,
            left + width,
            y + row - 2.0,
            y + row - 2.0
        );
        for s in outer.iter().filter(|s| &track_name(s).1 == name) {
            let (a, b) = (x(s.begin_ns), x(s.end_ns));
            let colour = colours[s.frame.unwrap_or(0) as usize % colours.len()];
            svg += &format!(
                "<rect x=\"{a:.1}\" y=\"{:.1}\" width=\"{:.2}\" height=\"{:.1}\" fill=\"{colour}\" \
                 stroke=\"white\" stroke-width=\"0.5\"><title>{} (frame {}): {:.3} ms</title></rect>\n",
                y + 4.0,
                (b - a).max(0.5),
                row - 10.0,
                s.name,
                s.frame.map_or("-".to_string(), |f| f.to_string()),
                s.ms()
            );
            if b - a > 6.0 * s.name.len() as f64 {
                svg += &format!(
                    "<text x=\"{:.1}\" y=\"{:.1}\" fill=\"white\">{}</text>\n",
                    a + 2.0,
                    y + 20.0,
                    s.name
                );
            }
        }
    }
    svg += "</svg>\n";
    svg
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_interpolate_between_ranks() {
        let v = [5.0, 1.0, 3.0, 2.0, 4.0];
        assert_eq!(quantile(&v, 0.5), 3.0);
        assert_eq!(quantile(&v, 0.0), 1.0);
        assert_eq!(quantile(&v, 1.0), 5.0);
        assert!((quantile(&v, 0.1) - 1.4).abs() < 1e-12);
        assert!((quantile(&v, 0.9) - 4.6).abs() < 1e-12);
        assert_eq!(
            quantile(&[2.0, 4.0], 0.5),
            3.0,
            "even count: mean of the middle two"
        );
        assert_eq!(quantile(&[], 0.5), 0.0);
    }
}
