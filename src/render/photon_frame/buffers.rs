//! The bounce map and photon map on the GPU, each over one or more buffers (hard case "more
//! photons than fit in one buffer", docs/stability.md): a storage buffer is read through one
//! descriptor, which reaches `maxStorageBufferRange` bytes at most (128 MiB on lavapipe: 4.2 M
//! bounce-map records, 2.8 M photons), so a larger map is split. The bounce map pass writes
//! each buffer of its map with a dispatch of its own (`passes/bounce_map.rs`), and the photon
//! volumes draw each photon buffer in turn (`passes/photon_volumes.rs`).

use crate::config::settings::RenderSettings;
use crate::gpu::{vk, Buffer, Gpu, MemoryLocation};
use crate::passes::bounce_map::{Split, MAX_BOUNCE_BUFFERS};
use crate::passes::photon_volumes;
use crate::photon::types::{BounceMapPhoton, Photon};
use std::sync::Arc;

/// The bounce map on the GPU: `split.records` records over buffers of `split.per_buffer`.
pub(super) struct BounceBuffers {
    pub(super) device: Vec<Buffer>,
    pub(super) split: Split,
}

impl BounceBuffers {
    /// Buffers for `records` bounce-map records, each bound with at most `range` bytes.
    pub(super) fn new(gpu: &Arc<Gpu>, records: usize, range: u64) -> anyhow::Result<Self> {
        let split = Split::new(records, range);
        anyhow::ensure!(
            split.buffers() <= MAX_BOUNCE_BUFFERS,
            "a bounce map of {records} records ({} bytes) needs {} buffers of {range} bytes, \
             more than the {MAX_BOUNCE_BUFFERS} the bounce map pass binds",
            records * size_of::<BounceMapPhoton>(),
            split.buffers()
        );
        let device = (0..split.buffers())
            .map(|b| {
                let records = split.records_of(b).len().max(1);
                Buffer::new(
                    gpu,
                    &format!("bounce_map[{b}]"),
                    (records * size_of::<BounceMapPhoton>()) as u64,
                    // TRANSFER_DST: the value check's test seam writes into it
                    // (`passes/value_check.rs`).
                    vk::BufferUsageFlags::STORAGE_BUFFER
                        | vk::BufferUsageFlags::TRANSFER_SRC
                        | vk::BufferUsageFlags::TRANSFER_DST,
                    MemoryLocation::GpuOnly,
                )
            })
            .collect::<Result<_, _>>()?;
        Ok(Self { device, split })
    }
}

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

    /// Writes the photon map, given as consecutive `parts` (e.g. chunks of it), into the
    /// staging buffers, `capacity` a buffer; a part may straddle two buffers.
    pub(super) fn write<P: AsRef<[Photon]>>(
        &mut self,
        parts: impl IntoIterator<Item = P>,
    ) -> anyhow::Result<()> {
        self.counts.fill(0);
        let mut written = 0;
        for part in parts {
            let mut part = part.as_ref();
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

/// The most bytes one storage buffer of the bounce map or photon map is bound with: what one
/// storage-buffer descriptor reaches on the device (`maxStorageBufferRange`), or less where
/// `RenderSettings::storage_buffer_range` says so.
pub(super) fn storage_buffer_range(gpu: &Gpu, settings: &RenderSettings) -> u64 {
    let device = u64::from(gpu.properties.max_storage_buffer_range);
    settings
        .storage_buffer_range
        .map_or(device, |n| n.clamp(1, device))
}

/// The most photons one photon buffer holds ([`storage_buffer_range`]; at least one).
pub(super) fn photons_per_buffer(gpu: &Gpu, settings: &RenderSettings) -> usize {
    let range = storage_buffer_range(gpu, settings) / size_of::<Photon>() as u64;
    usize::try_from(range).unwrap_or(usize::MAX).max(1)
}
