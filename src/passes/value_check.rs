//! Value check (compute, `RenderSettings::check_values`, `--check-values`): counts the NaN,
//! ±Inf and negative values in the frame's HDR buffers on the GPU, with atomics, into a small
//! host-visible buffer read back with the frame ([`ValueCheck`] in `FrameStats`, and the stats
//! JSON). A frame that does not ask for it records none of this.
//!
//! | buffer ([`Checked`]) | when (box D) | values | negative counted in |
//! |---|---|---|---|
//! | `direct` | before the composite adds indirect light | 4 per pixel | every channel |
//! | `bounce_map` | after it is back from the readback | 8 per record | power |
//! | `photon_map` | before the photon volumes draw it (every buffer of it) | 12 per photon | power |
//! | `indirect.low_irradiance`, `indirect.low_glossy` | after the photon volumes, before the upsample (`--subsample N > 1`) | 4 per pixel | every channel |
//! | `indirect` | before the composite | 4 per pixel | every channel |
//! | `final` | after the translucent pass, before tonemapping | 4 per pixel | every channel |
//!
//! A value is *non-finite* when its exponent bits are all set (NaN, ±Inf: a bit test, which no
//! compiler folds away), *negative* when finite, below zero and not -0.0; positions and packed
//! directions of photon records may be negative, so only their power is tested for sign. The
//! counters are 32-bit: a frame reads far fewer than 2³² values (a 4K image is 33 M).
//!
//! Each frame in flight has its own counters (`FRAMES_IN_FLIGHT` × [`SLOTS`] `ValueCounters`)
//! and descriptor sets, rewritten when its frame is recorded: the frame that used them last,
//! `FRAMES_IN_FLIGHT` frames earlier, has retired by then (`Renderer::submit_frame`), so a
//! photon buffer that grew is simply bound the next time.
//!
//! A bounce map or photon map split over several buffers (`photon_frame/buffers.rs`) is checked
//! buffer by buffer into the one counter of its map, so its `values` is the whole map's. A set
//! must not be rewritten while a command buffer that bound it is recording or pending, so each
//! check of a kind in a frame takes the next set of its own: the record kernel has
//! [`MAX_PHOTON_BUFFERS`] sets per frame in flight for the photon map and
//! [`MAX_BOUNCE_BUFFERS`] for the bounce map (the renderer refuses a map needing more buffers,
//! `PhotonBuffers::new`, `BounceBuffers::new`, and the passes bind no more), every other kind
//! one. The sets are allocated up front from a pool sized for that bound rather than from pools
//! grown on demand: `FRAMES_IN_FLIGHT` × (5 + 64 + 64) sets of two storage-buffer descriptors
//! is a small pool, and nothing is allocated while frames are recorded.
//!
//! **Test seam**: [`ValueCheckPass::inject`] writes a chosen value into a buffer just before
//! the check reads it (an image texel by a copy, a record's float by `vkCmdUpdateBuffer`), so
//! the tests prove the counter sees a bad value in every kind of buffer, and that what later
//! passes make of it is seen too.

use super::ComputeKernel;
use crate::gpu::{
    vk, Access, BindingKind, Buffer, Cmd, Filter, Gpu, Image, MemoryLocation, Sampler, Shaders, Use,
};
use crate::layout::ValueCounters;
use crate::passes::bounce_map::MAX_BOUNCE_BUFFERS;
use crate::passes::photon_volumes::MAX_PHOTON_BUFFERS;
use crate::timing::pass_id::PassId;
use std::ops::Range;
use std::sync::Arc;

/// Counter slots per frame: one per [`Checked`] buffer.
pub const SLOTS: usize = Checked::ALL.len();

/// Workgroups the record check dispatches at most (each of 256 invocations, grid-stride).
const MAX_RECORD_GROUPS: u32 = 1024;
/// Invocations per workgroup of `value_check_records.comp` (`local_size_x`).
const RECORD_GROUP: u32 = 256;
/// Bytes of one RGBA f32 texel.
const TEXEL_BYTES: usize = 16;

/// A buffer of the frame the value check reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Checked {
    /// The radiance image as the direct pass left it.
    Direct,
    BounceMap,
    PhotonMap,
    IndirectLowIrradiance,
    IndirectLowGlossy,
    /// The indirect radiance (full resolution, upsampled at `--subsample N > 1`).
    Indirect,
    /// The radiance image before tonemapping: direct + indirect, glass and mirrors drawn.
    Final,
}

impl Checked {
    pub const ALL: [Checked; 7] = [
        Checked::Direct,
        Checked::BounceMap,
        Checked::PhotonMap,
        Checked::IndirectLowIrradiance,
        Checked::IndirectLowGlossy,
        Checked::Indirect,
        Checked::Final,
    ];

    /// The name in [`BufferCheck::name`] and the stats JSON.
    pub fn name(self) -> &'static str {
        match self {
            Checked::Direct => "direct",
            Checked::BounceMap => "bounce_map",
            Checked::PhotonMap => "photon_map",
            Checked::IndirectLowIrradiance => "indirect.low_irradiance",
            Checked::IndirectLowGlossy => "indirect.low_glossy",
            Checked::Indirect => "indirect",
            Checked::Final => "final",
        }
    }

    fn slot(self) -> usize {
        self as usize
    }
}

/// What the value check counted in one buffer of a frame.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct BufferCheck {
    pub name: String,
    /// NaN or ±Inf values.
    pub non_finite: u64,
    /// Finite negative values where a negative is wrong (module docs).
    pub negative: u64,
    /// Values read (floats: 4 per pixel, 8 per bounce-map record, 12 per photon).
    pub values: u64,
}

/// The value check of one frame: its buffers in the order they were checked.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct ValueCheck {
    pub per_buffer: Vec<BufferCheck>,
}

impl ValueCheck {
    /// Non-finite plus negative values over every buffer.
    pub fn total_bad(&self) -> u64 {
        self.per_buffer
            .iter()
            .map(|b| b.non_finite + b.negative)
            .sum()
    }

    /// The check of the buffer named `name` ([`Checked::name`]), if the frame had it.
    pub fn buffer(&self, name: &str) -> Option<&BufferCheck> {
        self.per_buffer.iter().find(|b| b.name == name)
    }
}

/// How a buffer of photon records is laid out, in floats.
#[derive(Clone, Copy, Debug)]
pub struct Records {
    /// Records before this buffer in a map split over buffers (0 for the first or only one):
    /// injections address the whole map ([`ValueCheckPass::inject`]).
    pub first: u64,
    pub count: u32,
    /// Floats per record.
    pub stride: u32,
    /// Float index of the power (RGB) in a record.
    pub power_offset: u32,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ImagePush {
    width: u32,
    height: u32,
    counter: u32,
    unused: u32,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct RecordPush {
    count: u32,
    stride: u32,
    power_offset: u32,
    counter: u32,
}

/// A value to write into a buffer before the check reads it (test seam).
#[derive(Clone, Copy, Debug)]
struct Injection {
    buffer: Checked,
    /// Float index: `(y·width + x)·4 + channel` in an image, `record·stride + field` in records
    /// (the record counted over every buffer of a split photon map).
    index: u64,
    value: f32,
}

/// A compute kernel with descriptor sets per frame in flight and slot.
struct Kernel {
    kernel: ComputeKernel,
    /// `[frame][slot]`: the kernel's sets for the checks of a slot in one frame (module docs);
    /// written before each use.
    sets: Vec<Vec<Range<usize>>>,
}

impl Kernel {
    fn new(
        gpu: &Arc<Gpu>,
        name: &str,
        shader: &crate::gpu::Shader,
        (source, push_size): (BindingKind, usize),
        (frames, parts): (usize, fn(Checked) -> usize),
    ) -> anyhow::Result<Self> {
        let mut next = 0;
        let sets: Vec<Vec<Range<usize>>> = (0..frames)
            .map(|_| {
                Checked::ALL
                    .iter()
                    .map(|&c| {
                        next += parts(c);
                        next - parts(c)..next
                    })
                    .collect()
            })
            .collect();
        let kinds = [BindingKind::StorageBuffer, source];
        let shape = (&kinds[..], push_size as u32);
        let kernel = ComputeKernel::unwritten(gpu, (name, shader), shape, next)?;
        Ok(Self { kernel, sets })
    }

    /// Points the set of (`frame`, `which`, `part`) at `uses` and dispatches `groups` with
    /// `push` after their barriers.
    fn dispatch<T: bytemuck::Pod>(
        &self,
        cmd: &Cmd,
        (frame, which, part): (usize, Checked, usize),
        uses: &[Use],
        push: &T,
        groups: [u32; 3],
    ) -> anyhow::Result<()> {
        let sets = self.sets[frame][which.slot()].clone();
        let Some(set) = sets.clone().nth(part) else {
            anyhow::bail!(
                "value check: {} checked {} times in one frame, more than its {} descriptor sets",
                which.name(),
                part + 1,
                sets.len()
            );
        };
        self.kernel.rewrite(set, uses);
        cmd.uses(Shaders::Compute, uses);
        self.kernel.dispatch_set_with(cmd, set, push, groups);
        Ok(())
    }
}

pub struct ValueCheckPass {
    images: Kernel,
    records: Kernel,
    sampler: Sampler,
    /// `frames × SLOTS` counters, host-visible.
    counters: Buffer,
    /// One texel per slot: the values injected into images are copied from here.
    poison: Buffer,
    /// Per frame in flight: the buffers its frame checked, in order, each once.
    checked: Vec<Vec<Checked>>,
    /// Checks of each slot in the frame being recorded: the next one's set index.
    uses: [usize; SLOTS],
    /// The frame in flight being recorded.
    frame: usize,
    injections: Vec<Injection>,
}

/// Declares the value check's use of an HDR image it will check ([`ValueCheckPass::image`]),
/// while the image is planned: the check samples it, and its test seam copies texels into it.
pub fn watch(image: &Image) {
    let usage = vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST;
    image.require(usage, "an image the value check reads");
}

impl ValueCheckPass {
    /// The pass for `frames` frames in flight.
    pub fn new(gpu: &Arc<Gpu>, frames: usize) -> anyhow::Result<Self> {
        let images = Kernel::new(
            gpu,
            PassId::ValueCheck.name(),
            &crate::gpu::shader_table::VALUE_CHECK_COMP,
            (BindingKind::SampledImage, size_of::<ImagePush>()),
            (frames, |_| 1),
        )?;
        let records = Kernel::new(
            gpu,
            "value_check.records",
            &crate::gpu::shader_table::VALUE_CHECK_RECORDS_COMP,
            (BindingKind::StorageBuffer, size_of::<RecordPush>()),
            // Sets per frame in flight for the checks of each kind in one frame (module docs).
            (frames, |which| match which {
                Checked::PhotonMap => MAX_PHOTON_BUFFERS,
                Checked::BounceMap => MAX_BOUNCE_BUFFERS,
                _ => 1,
            }),
        )?;
        let counters = Buffer::new(
            gpu,
            "value_check.counters",
            (frames * SLOTS * size_of::<ValueCounters>()) as u64,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        let poison = Buffer::constants(
            gpu,
            "value_check.poison",
            (SLOTS * TEXEL_BYTES) as u64,
            vk::BufferUsageFlags::TRANSFER_SRC,
        )?;
        Ok(Self {
            images,
            records,
            sampler: Sampler::new(gpu, "value_check.nearest", Filter::Nearest, false)?,
            counters,
            poison,
            checked: vec![Vec::new(); frames],
            uses: [0; SLOTS],
            frame: 0,
            injections: Vec::new(),
        })
    }

    /// Starts the checks of the frame in flight `frame`: its counters are zeroed. The frame
    /// that used them before must have retired (and been [`Self::read`]).
    pub fn begin(&mut self, cmd: &Cmd, frame: usize) {
        self.frame = frame;
        self.checked[frame].clear();
        self.uses = [0; SLOTS];
        let zeros = [ValueCounters::default(); SLOTS];
        cmd.update_buffer(
            &self.counters,
            (frame * SLOTS * size_of::<ValueCounters>()) as u64,
            bytemuck::cast_slice(&zeros),
        );
    }

    /// Counts the bad values of the RGBA float `image`, named `which`.
    pub fn image(&mut self, cmd: &Cmd, which: Checked, image: &Image) -> anyhow::Result<()> {
        let _scope = cmd.scope(PassId::ValueCheck.name());
        for injection in self.take_injections(which, 0..u64::MAX) {
            let texel = injection.index / 4;
            let width = u64::from(image.width);
            let at = ((texel % width) as u32, (texel / width) as u32);
            let mut value = [0.0f32; 4];
            value[(injection.index % 4) as usize] = injection.value;
            let offset = (which.slot() * TEXEL_BYTES) as u64;
            cmd.update_buffer(&self.poison, offset, bytemuck::cast_slice(&value));
            cmd.copy_buffer_to_texel(&self.poison, offset, image, at);
        }
        let part = self.note(which);
        let push = ImagePush {
            width: image.width,
            height: image.height,
            counter: self.counter(which),
            unused: 0,
        };
        let uses = [
            Use::Write(&self.counters),
            Use::Sampled(image, &self.sampler),
        ];
        let groups = super::image_groups(image.width, image.height);
        self.images
            .dispatch(cmd, (self.frame, which, part), &uses, &push, groups)
    }

    /// Counts the bad values of the `records` in `buffer`, named `which`. The buffers of a map
    /// split over several are checked by one call each, into the same counter.
    pub fn records(
        &mut self,
        cmd: &Cmd,
        which: Checked,
        buffer: &Buffer,
        records: Records,
    ) -> anyhow::Result<()> {
        let part = self.note(which);
        if records.count == 0 {
            // Listed with no values: the buffer holds no record this frame (and may belong to
            // another queue), so injections wait for a frame that has some.
            return Ok(());
        }
        let _scope = cmd.scope(PassId::ValueCheck.name());
        let stride = u64::from(records.stride);
        let start = records.first * stride;
        let end = start + u64::from(records.count) * stride;
        for injection in self.take_injections(which, start..end) {
            let at = (injection.index - start) * 4;
            cmd.update_buffer(buffer, at, &injection.value.to_le_bytes());
        }
        let push = RecordPush {
            count: records.count,
            stride: records.stride,
            power_offset: records.power_offset,
            counter: self.counter(which),
        };
        let uses = [Use::Write(&self.counters), Use::Read(buffer)];
        let groups = records.count.div_ceil(RECORD_GROUP).min(MAX_RECORD_GROUPS);
        self.records
            .dispatch(cmd, (self.frame, which, part), &uses, &push, [groups, 1, 1])
    }

    /// Ends the frame's checks: its counters become readable by the host once it completes.
    pub fn end(&self, cmd: &Cmd) {
        cmd.transition_buffer(&self.counters, Access::HostRead);
    }

    /// The counts of the frame in flight `frame`, which has completed.
    pub fn read(&self, frame: usize) -> anyhow::Result<ValueCheck> {
        let bytes = self.counters.read()?;
        let size = size_of::<ValueCounters>();
        let per_buffer = self.checked[frame]
            .iter()
            .map(|&which| {
                let at = (frame * SLOTS + which.slot()) * size;
                let c: ValueCounters = bytemuck::pod_read_unaligned(&bytes[at..at + size]);
                BufferCheck {
                    name: which.name().to_string(),
                    non_finite: c.non_finite.into(),
                    negative: c.negative.into(),
                    values: c.values.into(),
                }
            })
            .collect();
        Ok(ValueCheck { per_buffer })
    }

    /// Test seam: at the next check of `buffer`, once, writes `value` at float `index` of it
    /// just before the check reads it (module docs). An image texel gets `value` in channel
    /// `index % 4` and 0 in the others. In a bounce map or photon map split over buffers,
    /// `index` counts over the whole map (`record·stride + field`, records in map order): the
    /// value lands in the buffer holding that record. An index past the records checked waits,
    /// unused.
    pub fn inject(&mut self, buffer: Checked, index: u64, value: f32) {
        self.injections.push(Injection {
            buffer,
            index,
            value,
        });
    }

    /// The injections into `which` whose float index lies in `floats`, taken out.
    fn take_injections(&mut self, which: Checked, floats: Range<u64>) -> Vec<Injection> {
        let (now, later) = self
            .injections
            .drain(..)
            .partition(|i| i.buffer == which && floats.contains(&i.index));
        self.injections = later;
        now
    }

    /// Notes a check of `which` in the frame being recorded (listed once however many buffers
    /// it spans) and returns its index among this frame's checks of `which`: its set.
    fn note(&mut self, which: Checked) -> usize {
        let checked = &mut self.checked[self.frame];
        if !checked.contains(&which) {
            checked.push(which);
        }
        let part = self.uses[which.slot()];
        self.uses[which.slot()] += 1;
        part
    }

    fn counter(&self, which: Checked) -> u32 {
        (self.frame * SLOTS + which.slot()) as u32
    }
}
