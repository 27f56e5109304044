//! Box C of the photon part of a frame, on the host: the CPU trace of the bounce map read back
//! by box A (`emission.rs`), with the kept lights' photons (`retrace.rs`), the photons' kNN
//! radii over the whole map (`photon_frame.rs`'s module docs, "Kernel radii"), the photon map
//! written to the staging buffers, and its copy to the GPU on the transfer queue for box D's
//! estimate (`estimate.rs`).

use super::buffers::PhotonBuffers;
use super::{drawn, retrace, PhotonFrame};
use crate::gpu::{Cmd, QueueRole};
use crate::photon::density::knn_radii_and_caustics;
use crate::photon::types::BounceMapPhoton;
use crate::render::stats::FrameStats;
use crate::timing;
use crate::timing::pass_id::PassId;
use rayon::prelude::*;
use std::ops::Range;

impl PhotonFrame {
    /// Box C, on the host once the readback has completed: traces the re-traced lights'
    /// bounce-map photons on every core, keeps the other lights' photons, and writes the photon
    /// map (light after light) into the staging buffer for [`Self::record_upload`]. The
    /// previous frame's upload must have completed.
    pub fn trace(&mut self) -> anyhow::Result<FrameStats> {
        let plan = &self.plan;
        let mut stats = FrameStats {
            bounce_map_records: plan.texels,
            lights_at_max_resolution: plan.lights_at_max_resolution.clone(),
            ..Default::default()
        };
        // Empty until this trace has packed its map: never an older map's photons.
        self.packed.clear();
        if plan.texels == 0 {
            self.buffers.counts.fill(0);
            self.traced.clear();
            self.radii.clear();
            self.caustic_photons = 0;
            return Ok(stats);
        }
        anyhow::ensure!(
            self.retrace.len() == self.scene.lights.len(),
            "the photon trace ran without its emission"
        );
        // Only the re-traced lights' records, straight from the mapped readback.
        let readback = &self.readback;
        let mut read = |texels: Range<usize>, out: &mut [BounceMapPhoton]| {
            let offset = (texels.start * size_of::<BounceMapPhoton>()) as u64;
            readback.read_into(offset, bytemuck::cast_slice_mut(out))
        };
        let frame = retrace::Frame {
            plan,
            scene: &self.scene,
            bvh: &self.bvh,
            trace: &self.trace,
            retrace: &self.retrace,
            sample: self.sample,
        };
        self.traced.update(&frame, &mut read, &mut stats)?;
        // The kernel radii over every light's photons (module docs, "Kernel radii"), before
        // anything can fail: the radii always match the kept photons.
        let (traced, neighbours) = (&self.traced, self.neighbours);
        (self.radii, self.caustic_photons) = timing::timed("photon density", || {
            knn_radii_and_caustics(traced.photons(), neighbours)
        });
        let count = self.traced.photon_count();
        if !self.buffers.holds(count) {
            // The old buffers go to the graveyard, destroyed once the frames using them finish.
            // The photons that were on the graphics queue were released in `record_emission`
            // (they have none now: the new buffers start out owned by nobody).
            let per_buffer = self.buffers.per_buffer;
            let capacity = count.next_power_of_two();
            self.buffers = PhotonBuffers::new(&self.gpu, count, capacity, per_buffer)?;
            self.rebind = true;
        }
        // Light after light, each light's photons where a fresh map has them, normals packed
        // with their radii (on every core, in order), then copied to the staging buffers.
        let (traced, radii, packed) = (&self.traced, &self.radii, &mut self.packed);
        timing::timed("upload write", || {
            let mut start = 0;
            for light in traced.light_photons() {
                let own = &radii[start..start + light.len()];
                packed.par_extend(
                    (light.par_iter().zip(own)).map(|(p, &r)| drawn(p, r, glam::Vec3::ZERO)),
                );
                start += light.len();
            }
            debug_assert_eq!(start, radii.len());
            self.buffers.write([packed.as_slice()])
        })?;
        stats.photon_buffers = self.buffers.counts.iter().filter(|&&n| n > 0).count();
        stats.bounce_map_buffers = self.bounce_map_buffers();
        Ok(stats)
    }

    /// Buffers of the bounce map holding this frame's records.
    fn bounce_map_buffers(&self) -> usize {
        let split = self.bounce_map.split;
        split.pieces(0..self.plan.texels).count()
    }

    /// The CPU→GPU copy of the photon map (on the transfer queue), handing it to the graphics
    /// queue for [`Self::record_estimate`].
    pub fn record_upload(&self, cmd: &Cmd) {
        if self.count() == 0 {
            return;
        }
        let _scope = cmd.scope(PassId::Upload.name());
        for (staging, photons) in self.buffers.used() {
            cmd.copy_buffer(staging, photons);
            cmd.release_buffer(photons, QueueRole::Graphics);
        }
    }
}
