//! Issuing a frame: [`Renderer::submit_frame`] (the script of boxes A–D in `render/frame.rs`'s docs),
//! the serial schedule's waits, and retiring a frame slot: its timestamps read as spans and its
//! stats completed ([`Renderer::finish`], [`Renderer::drain`]).

use super::{after, reuse_stats, PendingFrame, Renderer};
use crate::config::settings::Effects;
use crate::config::settings::{Schedule, SkippedPass, FRAMES_IN_FLIGHT};
use crate::gpu::{QueueRole, Recording, Span, TimelinePoint, Wait};
use crate::render::photon_frame::PhotonFrame;
use crate::render::stats::{pass_ran, FrameImage, FrameStats};
use crate::timing;
use crate::timing::pass_id::PassId;

impl Renderer {
    /// Issues one frame without waiting for the GPU to finish it (module docs: the schedule).
    /// At most [`FRAMES_IN_FLIGHT`] frames are in flight: the frame that last used this
    /// frame's slot is waited for first (in the steady state it has long finished).
    pub fn submit_frame(&mut self) -> anyhow::Result<()> {
        anyhow::ensure!(
            !self.broken,
            "the renderer stopped after an error in an earlier frame"
        );
        // Set until the frame is fully issued. The resources' tracked states stay consistent
        // after an error half way (a recording hands its states back only when submitted,
        // `gpu/tracker.rs`), but a buffer released to another queue family whose acquiring
        // submission never came (the bounce map, on a GPU with a transfer family) and the
        // slot's timestamp pool in use are not something the next frame can resume from, so
        // the renderer refuses further frames (the GPU is drained on drop).
        self.broken = true;
        let gpu = self.gpu.clone();
        let slot = (self.frame_index % FRAMES_IN_FLIGHT as u64) as usize;
        if let Some(retired) = self.retire_slot(slot)? {
            self.last_retired = Some(retired);
        }
        // The span covers the host's part of this frame only, so frames' spans never overlap
        // on the main thread's track.
        let frame_span = timing::frame(self.frame_index);
        let start_ns = timing::now_ns();
        gpu.collect_garbage();
        let timestamps = self.slots[slot].timestamps.clone();
        timestamps.reset(self.frame_index);
        // Progressive accumulation: a still frame joins the mean with a new photon sample (and
        // new points on the emitters, before the lights are set up).
        let accumulated = self.next_accumulation()?;
        let frame = self.prepare();
        // Nothing moved and no light changed since the photon map was traced: draw it again
        // (issue #9), without light G-buffers, bounce map, readback, trace or upload.
        let reuse = match &self.photon_map {
            Some(stats) if self.settings.effects == Effects::Auto => Some(stats),
            _ => None,
        };
        let mut stats = FrameStats::default();
        if let Some(reused) = reuse {
            stats = reused.clone();
        }
        let reuse = reuse.is_some();

        // Box A (graphics): per-frame constants, light G-buffers, bounce map.
        let a = gpu.record(QueueRole::Graphics, "box A", Some(timestamps.clone()))?;
        {
            let cmd = a.cmd();
            self.record_constants(&cmd, &frame);
            if let Some(photons) = &mut self.photons {
                if !reuse {
                    photons.record_emission(&cmd, &self.scene);
                }
            }
        }
        let a_done = self.submit(a, &[])?;

        // The bounce map's GPU→CPU copy (transfer queue).
        let emits = !reuse && self.photons.as_ref().is_some_and(PhotonFrame::emits);
        let readback_done = match &self.photons {
            Some(photons) if emits => {
                let rec = gpu.record(
                    QueueRole::Transfer,
                    PassId::Readback.name(),
                    Some(timestamps.clone()),
                )?;
                photons.record_readback(&rec.cmd());
                Some(self.submit(rec, &[after(a_done)])?)
            }
            _ => None,
        };

        // Box B (graphics): shadow maps, eye G-buffer, direct light.
        let b = gpu.record(QueueRole::Graphics, "box B", Some(timestamps.clone()))?;
        self.record_eye_and_direct(&b.cmd(), &frame);
        let b_done = self.submit(b, &[])?;
        // `Schedule::trace_beside_box_b`: on a CPU device the trace waits for box B (the serial
        // schedule has already waited for it).
        let schedule = self.settings.schedule;
        if !reuse
            && self.photons.is_some()
            && schedule != Schedule::Serial
            && !schedule.trace_beside_box_b(gpu.properties.is_cpu())
        {
            // The span's name is the reason, in the trace and the stats.
            timing::timed("box B wait: CPU device", || gpu.wait(b_done))?;
        }

        // Box C (host, all cores): trace the bounce map's photons while box B runs.
        let mut upload_done = None;
        if let (Some(photons), false) = (&mut self.photons, reuse) {
            if let Some(readback) = readback_done {
                timing::timed("readback wait", || gpu.wait(readback))?;
            }
            if let Some(previous) = self.last_upload.take() {
                // The staging buffer is free again (long done by now): the trace writes it,
                // also when every light's photons were kept.
                gpu.wait(previous)?;
            }
            // Without photons to emit (every light's mask off) the map is emptied.
            stats = photons.trace()?;
            // What glass and mirrors see of this map's indirect light
            // (`photon_frame/environment.rs`), gathered while the GPU still runs, one cube a probe; the
            // staging buffers they go to were read at most by the previous frame's box D.
            if let Some(translucent) = &mut self.translucent {
                let centres = translucent.centres();
                let cubes = timing::timed("environment indirect", || {
                    photons.environment_indirect(&centres)
                });
                if let Some(previous) = self.last_frame_done {
                    timing::timed("environment wait", || gpu.wait(previous))?;
                }
                translucent.set_indirect(&cubes)?;
            }
            // The photon map's CPU→GPU copy (transfer queue), after the previous frame's
            // photon volumes stopped reading the photon buffer and box A handed it over.
            if photons.has_photons() {
                let rec = gpu.record(
                    QueueRole::Transfer,
                    PassId::Upload.name(),
                    Some(timestamps.clone()),
                )?;
                photons.record_upload(&rec.cmd());
                let waits: Vec<Wait> = self
                    .last_frame_done
                    .into_iter()
                    .chain([a_done])
                    .map(after)
                    .collect();
                let done = self.submit(rec, &waits)?;
                upload_done = Some(done);
                self.last_upload = Some(done);
            }
            if self.settings.effects == Effects::Auto {
                self.photon_map = Some(reuse_stats(self.frame_index, &stats, &self.lights));
            }
        }

        // Box D (graphics): photon volumes, upsampling, composite, glass, tonemap.
        self.prepare_debug_view()?;
        let d = gpu.record(QueueRole::Graphics, "box D", Some(timestamps.clone()))?;
        self.record_estimate_and_finish(&d.cmd(), &frame, slot)?;
        // The upload (which itself follows the readback); the readback too, for frames whose
        // trace stored nothing: box D takes the bounce map back from the transfer queue.
        let waits: Vec<Wait> = upload_done
            .into_iter()
            .chain(readback_done)
            .map(after)
            .collect();
        let d_done = self.submit(d, &waits)?;
        stats.accumulated_frames = accumulated + 1;
        stats.photon_sample = self.photons.as_ref().map_or(0, PhotonFrame::sample);
        stats.kernel = self.photons.as_ref().map(PhotonFrame::kernel);
        stats.tiles = self.photons.as_ref().and_then(PhotonFrame::tile_stats);

        self.last_frame_done = Some(d_done);
        self.slots[slot].pending = Some(PendingFrame {
            done: d_done,
            stats,
            start_ns,
            index: self.frame_index,
        });
        self.frame_index += 1;
        self.broken = false;
        drop(frame_span);
        Ok(())
    }

    /// How many frames the next frame's accumulation already holds (0: it starts one), and
    /// the photon sample and kernel scale for it: a still frame after the first of an
    /// accumulation gets a new, independent photon map (sample `last_sample + 1`) and kernels
    /// shrunk as probabilistic progressive photon mapping shrinks them
    /// ([`crate::photon::progressive::progressive_scale`]).
    pub(super) fn next_accumulation(&mut self) -> anyhow::Result<u32> {
        if self.accumulate.is_none() {
            self.accumulated = 0;
            return Ok(0);
        }
        let frames = if self.still && self.plan.accumulate {
            self.accumulated
        } else {
            0
        };
        if frames > 0 {
            self.last_sample = self.last_sample.wrapping_add(1).max(1);
            self.photon_map = None;
        }
        if let Some(photons) = &mut self.photons {
            photons.set_sample(self.last_sample);
            photons.set_radius_scale(crate::photon::progressive::progressive_scale(frames));
        }
        self.accumulated = frames;
        self.place_area_samples(self.last_sample)?;
        Ok(frames)
    }

    /// Waits for every frame in flight and reads back the last one.
    pub fn finish(&mut self) -> anyhow::Result<FrameImage> {
        let (gpu_spans, stats) = self.drain()?;
        self.last_retired = Some((gpu_spans.clone(), stats.clone()));
        let gpu = self.gpu.clone();
        let hdr_bytes = gpu.read_image(&self.radiance)?;
        let ldr = gpu.read_image(&self.display)?;
        let hdr: Vec<f32> = bytemuck::pod_collect_to_vec(&hdr_bytes);
        gpu.collect_garbage();
        Ok(FrameImage {
            width: self.settings.width,
            height: self.settings.height,
            hdr,
            ldr,
            gpu_spans,
            stats,
        })
    }

    /// Waits for every frame in flight (oldest first) without reading images back; returns
    /// the last frame's GPU spans and stats, with the passes it ran and skipped and the lobes
    /// compiled out.
    pub fn drain(&mut self) -> anyhow::Result<(Vec<Span>, FrameStats)> {
        anyhow::ensure!(self.frame_index > 0, "no frame was submitted");
        let mut last = None;
        for k in (0..FRAMES_IN_FLIGHT as u64).rev() {
            if k < self.frame_index {
                let slot = ((self.frame_index - 1 - k) % FRAMES_IN_FLIGHT as u64) as usize;
                if let Some(retired) = self.retire_slot(slot)? {
                    last = Some(retired);
                }
            }
        }
        let (spans, mut stats) =
            last.ok_or_else(|| anyhow::anyhow!("the last frame was already retired"))?;
        stats.passes_run = spans.iter().map(|s| s.name.clone()).collect();
        stats.passes_run.dedup();
        stats.passes_skipped = self.skipped_passes(&stats);
        stats.variants_skipped = self.plan.variants_skipped(self.settings.bsdf_variant);
        stats
            .variants_skipped
            .extend((self.translucent.as_ref()).and_then(|t| t.variants_skipped()));
        stats.light_plan = self.plan.lights.clone();
        stats.subsample = self.settings.subsample_factor();
        Ok((spans, stats))
    }

    /// The passes `stats`' frame did not run, in frame order: the photon-map reuse's (already
    /// in `stats`), then the plan's (those that really did not run).
    pub(super) fn skipped_passes(&self, stats: &FrameStats) -> Vec<SkippedPass> {
        let ran = |pass| {
            pass_ran(
                pass,
                stats.passes_run.iter().map(String::as_str),
                stats.cpu_trace_ms,
            )
        };
        self.plan
            .passes()
            .into_iter()
            .filter_map(|p| {
                if let Some(reused) = stats
                    .passes_skipped
                    .iter()
                    .find(|s| s.name == p.name.name())
                {
                    return Some(reused.clone());
                }
                if p.run && p.name == PassId::Denoise && !ran(p.name) {
                    // Planned, but an accumulation this long gets no levels (passes/denoise.rs).
                    return Some(SkippedPass {
                        name: p.name.name().to_string(),
                        reason: format!(
                            "--denoise {}: {} frames accumulated, the filter has stopped",
                            self.settings.denoise, stats.accumulated_frames
                        ),
                    });
                }
                if p.run && p.name == PassId::FinePhotons && !ran(p.name) {
                    // Planned, but the photon map holds no caustic photon this frame.
                    return Some(SkippedPass {
                        name: p.name.name().to_string(),
                        reason: "no caustic photon in this frame's photon map".to_string(),
                    });
                }
                (!p.run && !ran(p.name)).then(|| SkippedPass {
                    name: p.name.name().to_string(),
                    reason: p.reason,
                })
            })
            .collect()
    }

    /// Submits `rec`; in the serial schedule, also waits for it.
    pub(super) fn submit(&self, rec: Recording, waits: &[Wait]) -> anyhow::Result<TimelinePoint> {
        let done = self.gpu.submit(rec, waits)?;
        if self.settings.schedule == Schedule::Serial {
            self.gpu.wait(done)?;
        }
        Ok(done)
    }

    /// Waits for the frame in `slot` (if any) and returns its GPU spans and stats.
    pub(super) fn retire_slot(
        &mut self,
        slot: usize,
    ) -> anyhow::Result<Option<(Vec<Span>, FrameStats)>> {
        let Some(pending) = self.slots[slot].pending.take() else {
            return Ok(None);
        };
        {
            let _wait = timing::span_in("host wait", Some(pending.index));
            self.gpu.wait(pending.done)?;
        }
        let spans = self.slots[slot].timestamps.read()?;
        let mut stats = pending.stats;
        let end_ns = spans
            .iter()
            .map(|s| s.end_ns)
            .max()
            .unwrap_or(pending.start_ns);
        stats.frame_ms = end_ns.saturating_sub(pending.start_ns) as f64 * 1e-6;
        if let Some(check) = &self.value_check {
            stats.value_check = Some(check.read(slot)?);
        }
        Ok(Some((spans, stats)))
    }
}
