//! The stats JSON of a frame (DESIGN.md §7): the paper's Table 2 columns and per-stage times.
//!
//! Stage times are the frame's own measurements, the ones `--trace` shows: GPU stages are the
//! summed GPU timestamp scopes of that name; `cpu_trace` is the main thread's `cpu_trace` span
//! and `frame` its `frame` span (host time from the frame's start to the end of its GPU work).

use crate::frame::FrameImage;
use crate::pass_id::PassId;
use crate::scene::Scene;
use serde_json::{json, Map, Value};

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
