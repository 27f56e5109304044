//! Box A of the photon part of a frame, on the GPU: the light views' uniforms, the light
//! G-buffers and the bounce map of the lights whose photons are traced again (`retrace.rs`),
//! and the bounce map's copy to the host on the transfer queue, which box C's trace
//! (`host_trace.rs`) reads.

use super::PhotonFrame;
use crate::gpu::scene::GpuScene;
use crate::gpu::{Access, Cmd, QueueRole, Resource};
use crate::passes::bounce_map::{BounceMapIo, ViewBatch};
use crate::photon::types::BounceMapPhoton;
use crate::timing::pass_id::PassId;
use std::ops::Range;

impl PhotonFrame {
    /// Whether this frame's [`Self::record_emission`] made bounce-map records to read back:
    /// a budget, a light with power, and a light whose photons are traced again.
    pub fn emits(&self) -> bool {
        !self.batches.is_empty()
    }

    /// Box A: the light views' uniforms, and the light G-buffers and bounce map of the lights
    /// whose photons are traced again (`retrace.rs`: the others' are kept); hands the bounce map
    /// to the transfer queue for [`Self::record_readback`], and the photon buffer (kept by the
    /// graphics queue while frames reuse the photon map) for [`Self::record_upload`]: the
    /// upload must wait for this submission.
    pub fn record_emission(&mut self, cmd: &Cmd, scene: &GpuScene) {
        let plan = &self.plan;
        let lights = self.scene.lights.len();
        self.retrace = self.traced.changed(plan, lights, self.reuse_lights);
        self.batches.clear();
        // Every photon buffer the graphics queue holds goes to the transfer queue, whatever
        // this frame uploads: also one that held photons only frames ago, and in a frame with
        // none, so the next upload finds each handed over. Nothing for a buffer already handed
        // over or never drawn, or on one queue family: the tracker knows who holds it.
        for photons in &self.buffers.device {
            cmd.release_buffer(photons, QueueRole::Transfer);
        }
        if plan.texels == 0 {
            // No photons this frame (the lights went dark): nothing to upload or draw.
            self.buffers.counts.fill(0);
            return;
        }
        // The re-traced lights' views, consecutive ones in one batch, cut where the bounce map's
        // buffers end (`passes/bounce_map.rs`).
        let mut ranges: Vec<Range<usize>> = Vec::new();
        for views in (0..lights)
            .filter(|&l| self.retrace[l])
            .map(|l| plan.light_views(l))
            .filter(|r| !r.is_empty())
        {
            match ranges.last_mut() {
                Some(last) if last.end == views.start => last.end = views.end,
                _ => ranges.push(views),
            }
        }
        let view_records = |v: usize| plan.texel_range(v..v + 1);
        let extent = |v: usize| plan.extents[v];
        let split = self.bounce_map.split;
        self.batches = ranges
            .iter()
            .flat_map(|r| ViewBatch::split(r.clone(), view_records, extent, split))
            .collect();
        if self.batches.is_empty() {
            return; // every light's photons are kept: nothing to draw, read back or trace
        }
        self.light_pass.update(cmd, &plan.uniforms);
        cmd.update_buffer(&self.views, 0, bytemuck::cast_slice(&plan.views));
        // Origin-relative models; each view's uniforms hold its light clip transform. The kept
        // lights' layers are not drawn (an empty extent): they hold what they held when those
        // lights were last traced, with the same views.
        let relative = scene.draws(plan.origin, None);
        let draws = vec![relative; plan.views.len()];
        let extents: Vec<(u32, u32)> = plan
            .extents
            .iter()
            .enumerate()
            .map(|(v, &e)| {
                if ranges.iter().any(|r| r.contains(&v)) {
                    e
                } else {
                    (0, 0)
                }
            })
            .collect();
        {
            let _scope = cmd.scope(PassId::LightGbuffers.name());
            self.light_pass
                .record(cmd, scene, &draws, &extents, &mut self.light_gbuffer);
        }
        let io = BounceMapIo {
            materials: &scene.materials,
            views: &self.views,
            light_gbuffer: &self.light_gbuffer,
            bounce_map: &self.bounce_map.device,
            split: self.bounce_map.split,
        };
        self.bounce_pass
            .record(cmd, &io, &self.batches, (self.trace.seed, self.sample));
        for buffer in &self.bounce_map.device {
            cmd.release_buffer(buffer, QueueRole::Transfer);
        }
    }

    /// The GPU→CPU copy of the bounce map's records this frame made (on the transfer queue),
    /// handing it back to the graphics queue.
    pub fn record_readback(&self, cmd: &Cmd) {
        if self.batches.is_empty() {
            return;
        }
        let _scope = cmd.scope(PassId::Readback.name());
        let record = size_of::<BounceMapPhoton>() as u64;
        let split = self.bounce_map.split;
        // Every buffer, also one without new records (each is handed back below), in one
        // barrier.
        let sources: Vec<(Resource, Access)> = self
            .bounce_map
            .device
            .iter()
            .map(|buffer| (Resource::Buffer(buffer), Access::TransferSrc))
            .collect();
        cmd.barriers(&sources);
        // Each buffer's new records to their places in the one readback buffer.
        for (b, buffer) in self.bounce_map.device.iter().enumerate() {
            let base = split.records_of(b).start;
            let regions: Vec<(Range<u64>, u64)> = self
                .batches
                .iter()
                .filter(|batch| batch.records.start / split.per_buffer == b)
                .map(|batch| {
                    let r = &batch.records;
                    let within = (r.start - base) as u64 * record..(r.end - base) as u64 * record;
                    (within, r.start as u64 * record)
                })
                .collect();
            cmd.copy_buffer_regions(buffer, &self.readback, &regions);
        }
        cmd.transition_buffer(&self.readback, Access::HostRead);
        for buffer in &self.bounce_map.device {
            cmd.release_buffer(buffer, QueueRole::Graphics);
        }
    }
}
