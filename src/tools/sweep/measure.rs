//! One configuration of the sweep, measured: its time per stage and its error.
//!
//! **Time (ISPM).** A fresh [`Renderer`] per configuration, overlapped schedule,
//! `Effects::All` as in `ispm bench`: every frame re-traces its photons (a planned frame of a
//! static scene would reuse the first frame's photon map, and the sweep would time only the
//! passes that remain), so the bounce map, its readback, the CPU trace and the upload are in
//! the cost of every frame. One warm-up frame, then `frames` frames in one timing capture
//! ([`bench::timed_frames`]): `frame_ms` is their wall time over their count (the period, with
//! frames in flight), the per-stage figures the medians over frames of each stage's total
//! ([`bench::stage_times`]; GPU passes outermost only, and the CPU photon trace).
//!
//! **Time (photon-gather baseline).** The CPU reference's wall time for one image, one sample
//! per pixel at pixel centres, on every core (it has no frames; `frames` runs are timed and the
//! median taken): its photon map is traced, a k-d tree built, and every pixel gathered.
//!
//! **Error.** Against the [`References`]: relMSE of the whole image, of the direct part
//! (ISPM: the frame minus its indirect buffer; baseline: its image minus the reference's direct
//! part, which it computes identically by next-event estimation at the pixel centres) and of
//! the indirect part (ISPM: `PhotonFrame::read_indirect`), and FLIP of the tonemapped images.
//! The error image is the frame rendered after the timed ones (same photons: the seed is fixed).
//!
//! **Accumulation (`accumulate` N > 1).** The image is the mean of N frames of one progressive
//! accumulation (each with new photons and smaller kernels, `passes/accumulate.rs`), started
//! after the warm-up frame; `frame_ms` is the wall time to that image (all N frames, the cost
//! a user waits for), the stages the medians of its first N − 1 frames, and the indirect part the
//! mean less the renderer's direct light (a `Method::Direct` render: deterministic).

use super::grid::Config;
use super::reference::References;
use crate::config::settings::{Effects, Knobs, Method, RenderSettings, Schedule};
use crate::gpu::Gpu;
use crate::photon::kernel::KernelSettings;
use crate::render::frame::Renderer;
use crate::scene::Scene;
use crate::timing::pass_id::PassId;
use crate::tools::bench;
use crate::tools::metrics::{difference, flip, rel_mse, rgba};
use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::sync::Arc;

/// What one configuration measured.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Measurement {
    /// Frame period (ms): wall time over frames.
    pub frame_ms: f64,
    /// Median per frame of the busiest GPU queue's passes (0 for the baseline).
    pub gpu_ms: f64,
    /// Median per frame of the CPU photon trace (the baseline: its whole image).
    pub cpu_ms: f64,
    /// Median per frame of each stage (`gpu.PASS`, `cpu.cpu_trace`, `cpu.photon_gather`).
    pub stages: BTreeMap<String, f64>,
    pub rel_mse: f64,
    pub rel_mse_direct: f64,
    pub rel_mse_indirect: f64,
    /// Mean LDR FLIP of the tonemapped images.
    pub flip: f64,
    /// The kernel radius `r_max` used (m).
    pub r_max: f32,
    /// Photons stored in the photon map (ISPM; the baseline: emitted).
    pub stored_photons: usize,
}

/// What a renderer produced for one configuration, before it is compared.
struct Rendered {
    frame_ms: f64,
    gpu_ms: f64,
    cpu_ms: f64,
    stages: BTreeMap<String, f64>,
    /// The whole image and its indirect part (RGBA f32).
    total: Vec<f32>,
    indirect: Vec<f32>,
    stored_photons: usize,
}

/// Measures `config` (module docs).
pub fn measure(
    gpu: &Arc<Gpu>,
    scene: &Scene,
    config: &Config,
    (width, height): (u32, u32),
    frames: u32,
    refs: &References,
) -> Result<Measurement> {
    let r_max = config.radius_scale
        * KernelSettings::scene_relative(&scene.bounds(), config.photons, None).r_max;
    let job = Job {
        scene,
        config,
        width,
        height,
        frames: frames.max(1),
        r_max,
    };
    let r = match config.method {
        Method::Ispm => job.ispm(gpu)?,
        Method::PhotonGather => job.gather(refs)?,
        other => anyhow::bail!(
            "method {}: the sweep measures ispm and photon-gather",
            other.name()
        ),
    };
    let direct = difference(&r.total, &r.indirect);
    Ok(Measurement {
        frame_ms: r.frame_ms,
        gpu_ms: r.gpu_ms,
        cpu_ms: r.cpu_ms,
        stages: r.stages,
        rel_mse: rel_mse(&r.total, &refs.total),
        rel_mse_direct: rel_mse(&direct, &refs.direct),
        rel_mse_indirect: rel_mse(&r.indirect, &refs.indirect),
        flip: flip(&r.total, &refs.total, width, height),
        r_max,
        stored_photons: r.stored_photons,
    })
}

/// One configuration to render.
struct Job<'a> {
    scene: &'a Scene,
    config: &'a Config,
    width: u32,
    height: u32,
    frames: u32,
    r_max: f32,
}

impl Job<'_> {
    fn ispm(&self, gpu: &Arc<Gpu>) -> Result<Rendered> {
        let (c, scene) = (self.config, self.scene);
        let accumulate = c.accumulate.max(1);
        let knobs = Knobs {
            method: Some(Method::Ispm),
            photons: Some(c.photons),
            bounces: Some(c.bounces),
            radius: Some(self.r_max),
            size: Some((self.width, self.height)),
            subsample: Some(c.subsample),
            upsample: Some(c.upsample),
            caustic_share: Some(c.caustic_share),
            schedule: Some(Schedule::Auto),
            effects: Some(Effects::All),
            density: Some(c.density),
            accumulate: Some(accumulate > 1),
            ..Default::default()
        };
        let settings = RenderSettings::from_knobs(&knobs, &scene.bounds())?;
        let mut renderer = Renderer::new(gpu, scene, settings)?;
        bench::timed_frames(&mut renderer, scene, 0, 1)?;
        let (frame_ms, spans, frame, indirect) = if accumulate > 1 {
            // The time to the image: `accumulate` frames from a fresh accumulation (the
            // warm-up frame is not in it), each tracing new photons (`Effects::All`).
            renderer.restart_accumulation(false);
            let start = crate::timing::now_ns();
            let (_, spans, _) = bench::timed_frames(&mut renderer, scene, 1, accumulate - 1)?;
            let frame = renderer.render()?;
            let total_ms = crate::timing::now_ns().saturating_sub(start) as f64 * 1e-6;
            anyhow::ensure!(
                frame.stats.accumulated_frames == accumulate,
                "the sweep's accumulation holds {} frames, not {accumulate}",
                frame.stats.accumulated_frames
            );
            // The mean's indirect part: the mean less the (deterministic) direct light.
            let direct = Knobs {
                method: Some(Method::Direct),
                accumulate: Some(false),
                ..knobs
            };
            let direct = RenderSettings::from_knobs(&direct, &scene.bounds())?;
            let direct = Renderer::new(gpu, scene, direct)?.render()?;
            let indirect = difference(&frame.hdr, &direct.hdr);
            (total_ms, spans, frame, indirect)
        } else {
            let (frame_ms, spans, _) = bench::timed_frames(&mut renderer, scene, 1, self.frames)?;
            let frame = renderer.render()?;
            let indirect = renderer
                .photons()
                .context("the ISPM renderer has no photon frame")?
                .read_indirect()?;
            (frame_ms, spans, frame, indirect)
        };
        let stages: BTreeMap<String, f64> = bench::stage_times(&spans, |s| {
            if s.is_gpu() {
                s.depth == 0
            } else {
                s.name == PassId::CpuTrace.name()
            }
        })
        .into_iter()
        .map(|(k, t)| (k, t.median))
        .collect();
        Ok(Rendered {
            frame_ms,
            gpu_ms: bench::quantile(&bench::gpu_per_frame(&spans), 0.5),
            cpu_ms: stages
                .get(&PassId::CpuTrace.stage_key())
                .copied()
                .unwrap_or(0.0),
            stages,
            total: frame.hdr,
            indirect,
            stored_photons: frame.stats.stored_photons,
        })
    }

    fn gather(&self, refs: &References) -> Result<Rendered> {
        let settings = crate::reference::RefSettings {
            width: self.width,
            height: self.height,
            spp: 1,
            jitter: false,
            photons: self.config.photons,
            bounces: self.config.bounces,
            radius: Some(self.r_max),
            seed: 0,
            ..Default::default()
        };
        let cancel = std::sync::atomic::AtomicBool::new(false);
        let mut times = Vec::new();
        let mut image = Vec::new();
        for _ in 0..self.frames {
            let start = crate::timing::now_ns();
            let rendered = crate::reference::render(
                self.scene,
                Method::PhotonGather,
                &settings,
                None,
                &cancel,
            )?;
            times.push(crate::timing::now_ns().saturating_sub(start) as f64 * 1e-6);
            image = rgba(&rendered.pixels);
        }
        let frame_ms = bench::quantile(&times, 0.5);
        Ok(Rendered {
            frame_ms,
            gpu_ms: 0.0,
            cpu_ms: frame_ms,
            stages: BTreeMap::from([("cpu.photon_gather".to_string(), frame_ms)]),
            indirect: difference(&image, &refs.direct),
            total: image,
            stored_photons: self.config.photons,
        })
    }
}
