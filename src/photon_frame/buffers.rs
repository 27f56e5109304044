//! The photon map on the GPU over one or more buffers (hard case "more photons than fit in one
//! buffer", docs/stability.md): a storage buffer is read through one descriptor, which reaches
//! `maxStorageBufferRange` bytes at most (128 MiB on lavapipe: 2.8 M photons), so a larger map
//! is split, and the photon volumes draw each buffer in turn (`passes/photon_volumes.rs`).

use crate::frame::RenderSettings;
use crate::gpu::{vk, Buffer, Gpu, MemoryLocation};
use crate::passes::photon_volumes;
use crate::photon::types::Photon;
use std::sync::Arc;

/// The photon map on the GPU, split over buffers of at most `per_buffer` photons (hard case
/// "more photons than fit in one buffer": a storage buffer is read through one descriptor,
/// which reaches `maxStorageBufferRange` bytes at most).
pub(super) struct PhotonBuffers {
    pub(super) staging: Vec<Buffer>,
    pub(super) device: Vec<Buffer>,
    /// Photons in each buffer this frame (0 for the buffers past the photon map's end).
    pub(super) counts: Vec<u32>,
    /// Photons each buffer holds.
    capacity: usize,
    pub(super) per_buffer: usize,
}

impl PhotonBuffers {
    /// Buffers for `photons` photons, each holding `capacity` (≤ `per_buffer`).
    pub(super) fn new(
        gpu: &Arc<Gpu>,
        photons: usize,
        capacity: usize,
        per_buffer: usize,
    ) -> anyhow::Result<Self> {
        let capacity = capacity.clamp(1, per_buffer);
        let buffers = photons.div_ceil(capacity).max(1);
        anyhow::ensure!(
            buffers <= photon_volumes::MAX_PHOTON_BUFFERS,
            "{photons} photons need {buffers} photon buffers of {capacity}, more than the {} \
             the photon volumes draw from",
            photon_volumes::MAX_PHOTON_BUFFERS
        );
        let bytes = (capacity * size_of::<Photon>()) as u64;
        let (mut staging, mut device) = (Vec::new(), Vec::new());
        for i in 0..buffers {
            staging.push(Buffer::new(
                gpu,
                &format!("photon_map[{i}].staging"),
                bytes,
                vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::CpuToGpu,
            )?);
            device.push(Buffer::new(
                gpu,
                &format!("photon_map[{i}]"),
                bytes,
                vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuOnly,
            )?);
        }
        Ok(Self {
            staging,
            device,
            counts: vec![0; buffers],
            capacity,
            per_buffer,
        })
    }

    pub(super) fn holds(&self, photons: usize) -> bool {
        photons <= self.capacity * self.device.len()
    }

    /// Writes the photon map, given as consecutive `parts` (e.g. each light's photons), into
    /// the staging buffers, `capacity` a buffer; a part may straddle two buffers.
    pub(super) fn write<'a>(
        &mut self,
        parts: impl IntoIterator<Item = &'a [Photon]>,
    ) -> anyhow::Result<()> {
        self.counts.fill(0);
        let mut written = 0;
        for mut part in parts {
            while !part.is_empty() {
                let (buffer, within) = (written / self.capacity, written % self.capacity);
                let n = part.len().min(self.capacity - within);
                let offset = (within * size_of::<Photon>()) as u64;
                self.staging[buffer].write(offset, bytemuck::cast_slice(&part[..n]))?;
                self.counts[buffer] += n as u32;
                written += n;
                part = &part[n..];
            }
        }
        Ok(())
    }

    /// The buffers with photons this frame.
    pub(super) fn used(&self) -> impl Iterator<Item = (&Buffer, &Buffer)> {
        self.staging
            .iter()
            .zip(&self.device)
            .zip(&self.counts)
            .filter(|(_, &n)| n > 0)
            .map(|(pair, _)| pair)
    }
}

/// The most photons one photon buffer holds: what one storage-buffer descriptor reaches on the
/// device, or fewer where `RenderSettings::photons_per_buffer` says so.
pub(super) fn photons_per_buffer(gpu: &Gpu, settings: &RenderSettings) -> usize {
    let device = (gpu.properties.max_storage_buffer_range as usize / size_of::<Photon>()).max(1);
    settings
        .photons_per_buffer
        .map_or(device, |n| n.clamp(1, device))
}
