//! What a frame reports, one floor below the frame's three parts (`frame`, `photon_frame`,
//! `translucent_frame`), which all fill it in: [`FrameImage`] and [`FrameStats`], the passes a
//! frame skipped and why, and the stats JSON (DESIGN.md §7): the paper's Table 2 columns and
//! per-stage times.
//!
//! Stage times are the frame's own measurements, the ones `--trace` shows: GPU stages are the
//! summed GPU timestamp scopes of that name; `cpu_trace` is the main thread's `cpu_trace` span
//! and `frame` its `frame` span (host time from the frame's start to the end of its GPU work).

use crate::config::settings::SkippedPass;
use crate::passes::photon_tiles::TileStats;
use crate::passes::value_check::ValueCheck;
use crate::scene::Scene;
use crate::timing::pass_id::PassId;
use crate::timing::Span;
use serde_json::{json, Map, Value};

/// A rendered frame read back to the host.
#[derive(Clone, Debug)]
pub struct FrameImage {
    pub width: u32,
    pub height: u32,
    /// Linear HDR radiance, RGBA f32, top row first.
    pub hdr: Vec<f32>,
    /// Tonemapped sRGB, RGBA8, top row first.
    pub ldr: Vec<u8>,
    /// GPU time of each pass.
    pub gpu_spans: Vec<Span>,
    pub stats: FrameStats,
}

impl FrameImage {
    /// GPU milliseconds of the frame's passes named `name` (timestamp scopes), summed: 0 for
    /// none (a fold from +0.0: `Sum` of no f64 is -0.0, which JSON would print).
    pub fn gpu_ms(&self, pass: PassId) -> f64 {
        self.gpu_spans
            .iter()
            .filter(|s| s.name == pass.name())
            .fold(0.0, |sum, s| sum + s.ms())
    }
}

/// The paper's Table 2 numbers for one frame.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct FrameStats {
    /// Photons the lights sent this frame (the budget, `--photons`, to within its binomial
    /// spread: src/plan/bounce_plan.rs, "Budget"), the reused lights' included.
    pub emitted_photons: usize,
    /// Bounce-map records (light-view texels) this frame: one per texel that may send a photon.
    pub bounce_map_records: usize,
    /// Photons that survived the first (GPU) bounce.
    pub bounce_map_photons: usize,
    pub stored_photons: usize,
    /// Photons alive after each bounce (the paper's Figure 10).
    pub attrition: Vec<u64>,
    pub cpu_trace_ms: f64,
    /// Host time from the frame's start (the host begins issuing it) to the end of its last
    /// GPU pass. Under the overlapped schedule frames overlap, so this is latency, not the
    /// frame period.
    pub frame_ms: f64,
    pub passes_run: Vec<String>,
    /// The passes of the frame that did not run, in frame order, each with the effects plan's
    /// reason (or the photon-map reuse's: nothing moved and no light changed).
    pub passes_skipped: Vec<SkippedPass>,
    /// The optional über-BSDF lobes compiled out of the frame's shaders and CPU photon trace
    /// (`glossy_lobe`; `delta_lobes`: mirror and refraction, so no caustic paths), each with the
    /// effects plan's reason (`EffectsPlan::variants_skipped`); then the translucent pass's
    /// `convex_shortcut` when some glass or mirror is drawn without it, naming the meshes that
    /// are not convex (`TranslucentPass::variants_skipped`).
    pub variants_skipped: Vec<SkippedPass>,
    /// Per light, what the effects plan gave it (shadow views and direct light, photons) and
    /// why: a light with neither was skipped.
    pub light_plan: Vec<crate::plan::LightPlan>,
    /// The subsample factor the frame used (after clamping to the image size).
    pub subsample: u32,
    /// The lights (indices in `scene.lights`) whose photons the frame traced: their light
    /// G-buffers, bounce map, readback and CPU trace ran (`photon_frame/retrace.rs`).
    pub lights_retraced: Vec<usize>,
    /// The lights whose photons the frame kept from an earlier frame, each with why: all of
    /// them in a frame that reuses the whole photon map.
    pub lights_reused: Vec<ReusedLight>,
    /// Bounce-map photons the frame traced on the CPU: `bounce_map_photons` less the reused
    /// lights' (0 in a frame that reuses the whole map).
    pub traced_bounce_map_photons: usize,
    /// Photon buffers the photon map was split over (0 without photons; more than 1 past
    /// `RenderSettings::storage_buffer_range`).
    pub photon_buffers: usize,
    /// Buffers the frame's bounce map spans (0 without photons; more than 1 past
    /// `RenderSettings::storage_buffer_range`).
    pub bounce_map_buffers: usize,
    /// The lights whose photon budget asked for light views larger than
    /// `bounce_plan::MAX_RESOLUTION`² texels: they emit fewer photons than their share of `--photons`.
    pub lights_at_max_resolution: Vec<usize>,
    /// The NaN, ±Inf and negative values in the frame's buffers, counted on the GPU
    /// (`RenderSettings::check_values`; `None` when off).
    pub value_check: Option<ValueCheck>,
    /// Frames in the image's mean (`RenderSettings::accumulate`; 1 for a frame that stands
    /// alone).
    pub accumulated_frames: u32,
    /// The photon sample the frame's photon map was traced with (0: the frame-coherent one).
    pub photon_sample: u32,
    /// The photon kernels' clamp, scale and footprint floor the frame's estimate used (`None`
    /// without photons). Written by `stats::frame_json` with its glossy cap.
    #[serde(skip)]
    pub kernel: Option<crate::photon::kernel::KernelSettings>,
    /// The tiled estimator's lists of the frame (`--density tiled`; `None` with the photon
    /// volumes or without a photon part).
    pub tiles: Option<TileStats>,
}

/// A light whose photons a frame kept, and why.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct ReusedLight {
    /// Its index in `scene.lights`.
    pub light: usize,
    pub name: String,
    pub reason: String,
}

impl ReusedLight {
    /// Light `light` named `name`, unchanged since it was traced: `what` was reused.
    pub fn new(light: usize, name: &str, what: &str) -> Self {
        Self {
            light,
            name: name.to_string(),
            reason: format!("light {light} ({name}) unchanged: {what}"),
        }
    }
}

/// The photon passes a frame that reuses the last photon map skips: the emission and trace
/// ([`TRACE_PASSES`]), then the upload.
pub(crate) const REUSE_SKIPS: &[PassId] = &[
    PassId::LightGbuffers,
    PassId::BounceMap,
    PassId::Readback,
    PassId::CpuTrace,
    PassId::Upload,
];

/// The photon passes a frame in which every light keeps its photons skips (the kept map is
/// still uploaded: `photon_frame/retrace.rs`).
pub(crate) const TRACE_PASSES: &[PassId] = REUSE_SKIPS.split_at(4).0;

/// Did `pass` run in a frame whose GPU scopes were named `scopes` and whose photon trace took
/// `cpu_trace_ms`: the one rule of the stats' `passes_skipped` and the viewer's overlay.
pub fn pass_ran<'a>(
    pass: PassId,
    mut scopes: impl Iterator<Item = &'a str>,
    cpu_trace_ms: f64,
) -> bool {
    match pass {
        PassId::CpuTrace => cpu_trace_ms > 0.0,
        _ => scopes.any(|s| s == pass.name()),
    }
}

/// `passes` as skipped passes, each for `reason`.
pub(crate) fn skipped(passes: &[PassId], reason: &str) -> Vec<SkippedPass> {
    passes
        .iter()
        .map(|pass| SkippedPass {
            name: pass.name().to_string(),
            reason: reason.to_string(),
        })
        .collect()
}

/// The stages the stats always report (0 when a stage did not run), in frame order
/// ([`PassId::in_stats`]); `ms.frame` follows them (the main thread's `frame` span).
pub fn stages() -> impl Iterator<Item = PassId> {
    PassId::ALL.into_iter().filter(|p| p.in_stats())
}

/// Builds the stats object of `frame`.
pub fn frame_json(
    scene: &Scene,
    frame: &FrameImage,
    triangles: usize,
    bounces: u32,
    validation_messages: usize,
) -> Value {
    let mut ms = Map::new();
    for stage in stages() {
        let value = match stage {
            // A host-side span (timing::span guard) of the frame.
            PassId::CpuTrace => frame.stats.cpu_trace_ms,
            // GPU timestamp scopes.
            _ => frame.gpu_ms(stage),
        };
        ms.insert(stage.name().to_string(), json!(value));
    }
    ms.insert("frame".to_string(), json!(frame.stats.frame_ms));
    let s = &frame.stats;
    json!({
        "triangles": triangles,
        "lights": scene.lights.len(),
        // The lights the frame drew beyond the file's: points sampled on its emitters.
        "area_sample_lights": s.light_plan.len().saturating_sub(scene.lights.len()),
        "emitted_photons": s.emitted_photons,
        "bounce_map_records": s.bounce_map_records,
        "bounce_map_photons": s.bounce_map_photons,
        "stored_photons": s.stored_photons,
        "accumulated_frames": s.accumulated_frames,
        "photon_sample": s.photon_sample,
        // The kernel radius clamp (metres), the progressive scale, the footprint floor and the
        // glossy regularisation's cap (`photon::kernel`).
        "kernel": s.kernel.map(|k| json!({
            "r_min": k.r_min,
            "r_max": k.r_max,
            "scale": k.scale,
            "footprint": k.footprint,
            "footprint_max": k.footprint_max,
            "gather_exponent_max": k.gather_exponent_max(),
        })),
        // The density estimator's pass, and the tiled one's lists (`passes/photon_tiles.rs`).
        "density": match (s.tiles.is_some(), s.kernel.is_some()) {
            (true, _) => Some("tiled"),
            (false, true) => Some("volumes"),
            (false, false) => None,
        },
        "tiles": s.tiles,
        "bounces": bounces,
        "attrition": s.attrition,
        "width": frame.width,
        "height": frame.height,
        "subsample": s.subsample,
        "ms": ms,
        "passes_run": s.passes_run,
        "passes_skipped": s.passes_skipped,
        "variants_skipped": s.variants_skipped,
        "light_plan": s.light_plan,
        "lights_retraced": s.lights_retraced,
        "lights_reused": s.lights_reused,
        "traced_bounce_map_photons": s.traced_bounce_map_photons,
        // Buffers the bounce map and photon map were split over (more than 1 past one storage
        // buffer's reach, `maxStorageBufferRange`).
        "bounce_map_buffers": s.bounce_map_buffers,
        // Lights whose budget asked for views past the largest light view (they emit less).
        "lights_at_max_resolution": s.lights_at_max_resolution,
        "photon_buffers": s.photon_buffers,
        // `--check-values`: per buffer, the NaN/±Inf and negative values counted on the GPU.
        "value_check": s.value_check.as_ref().map(|c| json!({
            "per_buffer": c.per_buffer,
            "total_bad": c.total_bad(),
        })),
        "validation_messages": validation_messages,
    })
}
