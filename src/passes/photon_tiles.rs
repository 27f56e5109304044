//! Tiled density estimation (`--density tiled`): the photon volumes' radiance estimate
//! (`photon_volumes.rs`), gathered in compute instead of splatted by the rasteriser — the
//! method that won in Mara, McGuire & Luebke (I3D 2013).
//!
//! ```text
//!   CPU (passes/photon_tiles/lists.rs), per frame   GPU (photon_tiles.comp), one workgroup per tile
//!   each photon's bounding sphere            ┌────────────┐  each subgroup reads the list a
//!   → the screen tiles it may cover          │ tile t     │  subgroup's width at a time, keeps
//!   → per tile, a list of photons ─────────► │ 8×8 pixels │  the photons whose sphere reaches
//!     (offsets, indices, spheres; per slot)  │            │  its pixels' box, passes them lane
//!                                            └────────────┘  to lane (shuffles), and every
//!                                                            pixel tests them and sums
//! ```
//!
//! Each pixel sets up its surface and BSDF once (the glossy lobe's directional albedo
//! included), then pays a few multiplies for each listed photon that misses it, where a photon
//! volume pays for rasterising and shading a fragment. On lavapipe the volumes' cost is
//! fragment invocations, not arithmetic, so the gather is 3.5–5× cheaper there; on an NVIDIA
//! H100 it is 13–280× cheaper, the volumes' overlapping fragments costing far more than the
//! gather's culled list (docs/performance.md, "Density estimators"). `--density auto` picks
//! the gather wherever the device has its subgroup operations ([`crate::config::settings::Density`]);
//! the volumes stay for devices without them and as the paper's method to compare against.
//! No shared memory and no barrier: llvmpipe runs a workgroup's
//! SIMD vectors as coroutines, and barriers made a shared-memory version 3× slower than the
//! photon volumes.
//!
//! Workgroup i takes tile `order[i]`, an order the host writes after the list offsets
//! ([`order`]): row-major on a GPU; on lavapipe, which gives each of its threads one block of
//! consecutive workgroups, one in which every block holds its share of the lists' cost.
//!
//! The sums, channel for channel, are the fragment shaders': the support normalisation and
//! the upsampling read them unchanged. A dispatch gathers at most [`TILE_JOB`] entries of each
//! tile's list (llvmpipe ends an invocation's loops after 65535 iterations in all, silently);
//! longer lists and further photon buffers take further dispatches, each continuing the sums
//! where the last one left them, in list order, so the result is the one-pass sum bit for bit.
//!
//! The lists are written into host-visible buffers, one set per frame slot, so a frame never
//! writes lists that a frame still in flight reads; the slot's descriptor sets follow its
//! buffers when they grow, and are rewritten for new photon buffers only when that slot comes
//! round again (its last frame has finished by then).

use super::photon_volumes::{PhotonVolumeInputs, MAX_PHOTON_BUFFERS};
use crate::gpu::{
    uses, vk, Binding, Buffer, Cmd, ComputeDesc, DescriptorLayout, DescriptorSet, Filter, Gpu,
    Image, MemoryLocation, Pipeline, Sampler, Shaders, SpecConstant, Use,
};
use crate::layout::shared_constants::{SPEC_ID_SUBSAMPLED, TILE_JOB};
use crate::photon::bsdf::BsdfVariant;
use crate::photon::kernel::KernelSettings;
use crate::timing::pass_id::PassId;
use std::sync::Arc;

pub mod lists;
pub mod order;

use lists::TileLists;
use order::{dispatch_order, TileOrder};

/// What the tiled estimator gathered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct TileStats {
    /// Screen tiles (PHOTON_TILE² target pixels each).
    pub tiles: usize,
    /// List entries over all tiles: photons listed, each once per tile it may reach.
    pub entries: usize,
    /// The longest tile list.
    pub longest: usize,
    /// Dispatches of the gather (one per TILE_JOB entries of the longest list, per buffer).
    pub dispatches: usize,
}

impl TileStats {
    /// The stats of two estimates of one frame (at `--subsample N > 1`, the coarse photons' at
    /// 1/N and the fine photons' at full resolution): tiles (of both grids), entries and
    /// dispatches added, the longest list of either.
    pub fn and(self, other: Self) -> Self {
        Self {
            tiles: self.tiles + other.tiles,
            entries: self.entries + other.entries,
            longest: self.longest.max(other.longest),
            dispatches: self.dispatches + other.dispatches,
        }
    }
}

/// The push constants (`Push` in `photon_tiles.comp`).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    r_min: f32,
    r_max: f32,
    tile_columns: u32,
    subsample: u32,
    footprint: f32,
    footprint_max: f32,
    scale: f32,
    gather_exponent_max: f32,
    offset: [f32; 4],
    width: u32,
    height: u32,
    first: u32,
    accumulate: u32,
    start: u32,
    photon_base: u32,
    /// 1: the fine photons, added to `targets[0]` alone ([`PhotonTilesPass::record`]).
    fine: u32,
    /// Workgroup i gathers tile `offsets[tile_list + i]`, for i < `listed` (the dispatch's
    /// workgroups past them return at once: it is made 2-D to stay within the device's
    /// workgroup counts): the tiles in the order of [`order`].
    tile_list: u32,
    listed: u32,
    pad: [u32; 3],
}
const _: () = assert!(std::mem::offset_of!(Push, offset) == 32);
const _: () = assert!(std::mem::offset_of!(Push, width) == 48);
const _: () = assert!(std::mem::offset_of!(Push, start) == 64);
const _: () = assert!(size_of::<Push>() == 96);

/// One frame slot's lists and descriptor sets (one set per photon buffer).
struct Slot {
    offsets: Buffer,
    indices: Buffer,
    spheres: Buffer,
    sets: Vec<DescriptorSet>,
    /// The photon buffers changed since the sets were written.
    stale: bool,
}

pub struct PhotonTilesPass {
    gpu: Arc<Gpu>,
    pipeline: Pipeline,
    layout: DescriptorLayout,
    slots: Vec<Slot>,
    sampler: Sampler,
    subsample: u32,
    /// The order in which a dispatch's workgroups take the tiles (resolved for the device).
    order: TileOrder,
}

/// The lists' buffers start at this many bytes and double as needed.
const MIN_LIST_BYTES: u64 = 1 << 16;

fn list_buffer(gpu: &Arc<Gpu>, name: &str, bytes: u64) -> anyhow::Result<Buffer> {
    Ok(Buffer::new(
        gpu,
        name,
        bytes.max(MIN_LIST_BYTES).next_power_of_two(),
        vk::BufferUsageFlags::STORAGE_BUFFER,
        MemoryLocation::CpuToGpu,
    )?)
}

impl PhotonTilesPass {
    /// The pass at `subsample` (1: full resolution, else the 1/`subsample` targets) with the
    /// über-BSDF lobes of `variant`, its tiles in `order`, with lists for `slots` frames in
    /// flight.
    pub fn new(
        gpu: &Arc<Gpu>,
        inputs: &PhotonVolumeInputs,
        (subsample, variant, order): (u32, BsdfVariant, TileOrder),
        (slots, targets): (usize, &[&Image]),
    ) -> anyhow::Result<Self> {
        let sampler = Sampler::new(gpu, "photon_tiles.nearest", Filter::Nearest, false)?;
        // The kinds are every photon buffer's and slot's (any buffer stands in).
        let any = inputs.materials;
        let kinds = uses::kinds(&gather_uses(
            inputs,
            (any, true),
            (any, any, any),
            targets,
            &sampler,
        ));
        let bindings = Binding::sequence(&kinds, vk::ShaderStageFlags::COMPUTE);
        let layout = DescriptorLayout::new(
            gpu,
            PassId::PhotonTiles.name(),
            &bindings,
            (MAX_PHOTON_BUFFERS * slots.max(1)) as u32,
        )?;
        let subsample = subsample.max(1);
        let [a, b] = super::bsdf_constants(variant);
        let pipeline = Pipeline::compute(
            gpu,
            &ComputeDesc {
                name: PassId::PhotonTiles.name(),
                shader: &crate::gpu::shader_table::PHOTON_TILES_COMP,
                set_layouts: &[&layout],
                push_constant_size: size_of::<Push>() as u32,
                specialization: &[a, b, SpecConstant::bool(SPEC_ID_SUBSAMPLED, subsample > 1)],
            },
        )?;
        let mut pass = Self {
            gpu: gpu.clone(),
            pipeline,
            layout,
            slots: Vec::new(),
            sampler,
            subsample,
            order: order.resolve(gpu.properties.is_cpu()),
        };
        for i in 0..slots.max(1) {
            let slot = Slot {
                offsets: list_buffer(gpu, &format!("photon_tiles.offsets[{i}]"), 0)?,
                indices: list_buffer(gpu, &format!("photon_tiles.indices[{i}]"), 0)?,
                spheres: list_buffer(gpu, &format!("photon_tiles.spheres[{i}]"), 0)?,
                sets: Vec::new(),
                stale: true,
            };
            pass.slots.push(slot);
        }
        for i in 0..pass.slots.len() {
            pass.write_sets(i, inputs, targets)?;
        }
        Ok(pass)
    }

    fn write_sets(
        &mut self,
        slot: usize,
        inputs: &PhotonVolumeInputs,
        targets: &[&Image],
    ) -> anyhow::Result<()> {
        anyhow::ensure!(
            inputs.photons.len() <= MAX_PHOTON_BUFFERS,
            "the photon map needs {} photon buffers, more than the {MAX_PHOTON_BUFFERS} the \
             tiled estimator can read",
            inputs.photons.len()
        );
        let s = &mut self.slots[slot];
        for (i, photons) in inputs.photons.iter().enumerate() {
            let lists = (&s.offsets, &s.indices, &s.spheres);
            let writes = uses::writes(&gather_uses(
                inputs,
                (photons, true),
                lists,
                targets,
                &self.sampler,
            ));
            match s.sets.get(i) {
                Some(&set) => self.layout.update(set, &writes),
                None => s.sets.push(self.layout.allocate(&writes)?),
            }
        }
        s.stale = false;
        Ok(())
    }

    /// Points the pass at new photon buffers: each slot's sets are rewritten the next time
    /// that slot records (a frame still in flight may be reading the old ones).
    pub fn rebind(&mut self) {
        for slot in &mut self.slots {
            slot.stale = true;
        }
    }

    /// Gathers `counts[i]` photons from photon buffer `i`, as listed in `lists`, with the
    /// radii of `kernel` and `offset` (origin − eye) into `targets` (the photon volumes'):
    /// `[indirect, global, weight]` at subsample 1, else `[irradiance, glossy, global, weight]`.
    /// With `add` (the fine photons at full resolution when subsampling,
    /// `render/photon_frame/estimate.rs`), into `[indirect]` alone, added to what it holds.
    /// Only the first dispatch without `add` covers every tile (it clears the targets); the
    /// others cover the tiles with entries left for them. `slot` is the frame slot, whose
    /// previous frame has finished.
    pub fn record(
        &mut self,
        cmd: &Cmd,
        inputs: &PhotonVolumeInputs,
        (counts, kernel, offset): (&[u32], &KernelSettings, glam::Vec3),
        (lists, slot): (&TileLists, usize),
        (targets, add): (&[&Image], bool),
    ) -> anyhow::Result<TileStats> {
        let gpu = self.gpu.clone();
        // Each dispatch takes its tiles in `self.order`, listed after the offsets: buffer b's
        // dispatch j (entries j·TILE_JOB onwards of each list) from `jobs[b][j]` on. Every
        // tile for the first dispatch, which clears the targets; in the others (and all of
        // them with `add`, where the first adds too) only the tiles with entries left: an empty
        // tile's workgroup costs as much to launch as to skip on llvmpipe, 20 ms for the 4800
        // of 640×480.
        let mut offsets_and_tiles = lists.offsets.clone();
        let mut jobs: Vec<Vec<(u32, u32)>> = Vec::with_capacity(counts.len());
        for b in 0..counts.len() {
            let lengths = lists.lengths(b);
            let longest = lengths.iter().copied().max().unwrap_or(0);
            let count = longest.div_ceil(TILE_JOB).max(1);
            let buffer_jobs = (0..count)
                .map(|j| {
                    let tile_list = offsets_and_tiles.len() as u32;
                    let all = b == 0 && !add && j == 0;
                    let start = j * TILE_JOB;
                    offsets_and_tiles.extend(dispatch_order(&lengths, start, all, self.order));
                    (tile_list, offsets_and_tiles.len() as u32 - tile_list)
                })
                .collect();
            jobs.push(buffer_jobs);
        }
        let offsets: &[u8] = bytemuck::cast_slice(&offsets_and_tiles);
        let indices: &[u8] = bytemuck::cast_slice(&lists.indices);
        let spheres: &[u8] = bytemuck::cast_slice(&lists.spheres);
        let reach = u64::from(gpu.properties.max_storage_buffer_range);
        for (what, bytes) in [
            ("offsets", offsets),
            ("indices", indices),
            ("spheres", spheres),
        ] {
            anyhow::ensure!(
                bytes.len() as u64 <= reach,
                "the tiled gather's photon lists need {} bytes of {what}, more than one storage \
                 buffer reaches on this device ({reach}): use --density volumes or fewer photons",
                bytes.len()
            );
        }
        let s = &mut self.slots[slot];
        if offsets.len() as u64 > s.offsets.size {
            s.offsets = list_buffer(&gpu, &s.offsets.name.clone(), offsets.len() as u64)?;
            s.stale = true;
        }
        if indices.len() as u64 > s.indices.size {
            s.indices = list_buffer(&gpu, &s.indices.name.clone(), indices.len() as u64)?;
            s.stale = true;
        }
        if spheres.len() as u64 > s.spheres.size {
            s.spheres = list_buffer(&gpu, &s.spheres.name.clone(), spheres.len() as u64)?;
            s.stale = true;
        }
        if s.stale || s.sets.len() < inputs.photons.len() {
            self.write_sets(slot, inputs, targets)?;
        }
        let s = &self.slots[slot];
        s.offsets.write(0, offsets)?;
        s.indices.write(0, indices)?;
        s.spheres.write(0, spheres)?;

        let scope = match add {
            true => PassId::FinePhotons,
            false => PassId::PhotonTiles,
        };
        let _scope = cmd.scope(scope.name());
        let (width, height) = (targets[0].width, targets[0].height);
        let mut first_dispatch = true;
        let mut dispatches = 0;
        let mut photon_base = 0u32;
        for (b, (photons, &count)) in inputs.photons.iter().zip(counts).enumerate() {
            let base = photon_base;
            photon_base += count;
            // Buffer 0 always: its empty lists clear the targets when there are no photons.
            // Then, and adding, only the buffers whose photons some tile lists.
            if (b > 0 || add) && jobs[b][0].1 == 0 {
                continue;
            }
            // Only when read: an unread photon buffer may belong to the transfer queue.
            let lists_of_slot = (&s.offsets, &s.indices, &s.spheres);
            let uses = gather_uses(
                inputs,
                (photons, count > 0),
                lists_of_slot,
                targets,
                &self.sampler,
            );
            // TILE_JOB entries of every tile's list per dispatch (`photon_tiles.comp`).
            for (job, &(tile_list, listed)) in jobs[b].iter().enumerate() {
                // The targets wait for the dispatch before (each continues its sums).
                cmd.uses(Shaders::Compute, &uses);
                cmd.bind_pipeline(&self.pipeline);
                cmd.bind_sets(&self.pipeline, 0, &[s.sets[b]]);
                cmd.push_constants(
                    &self.pipeline,
                    &Push {
                        r_min: kernel.r_min,
                        r_max: kernel.r_max,
                        tile_columns: lists.columns,
                        subsample: self.subsample,
                        footprint: kernel.footprint,
                        footprint_max: kernel.footprint_max,
                        scale: kernel.scale,
                        gather_exponent_max: kernel.gather_exponent_max(),
                        offset: offset.extend(0.0).to_array(),
                        width,
                        height,
                        first: lists.first(b),
                        accumulate: u32::from(!first_dispatch),
                        start: job as u32 * TILE_JOB,
                        photon_base: base,
                        fine: u32::from(add),
                        tile_list,
                        listed,
                        pad: [0; 3],
                    },
                );
                let max = gpu.properties.max_compute_work_group_count_x;
                let (x, y) = rows_of(listed, max);
                cmd.dispatch(x, y, 1);
                first_dispatch = false;
                dispatches += 1;
            }
        }
        Ok(TileStats {
            tiles: lists.tiles(),
            entries: lists.indices.len(),
            longest: (0..counts.len())
                .map(|b| lists.longest(b))
                .max()
                .unwrap_or(0),
            dispatches,
        })
    }
}

/// The workgroup grid of a dispatch over `listed` tiles, one each in row-major order, with at
/// most `max` per row (the device's workgroups per dimension: 65 535 on lavapipe, 4.2
/// megapixels of 8×8 tiles); the last row's workgroups past `listed` return at once.
fn rows_of(listed: u32, max: u32) -> (u32, u32) {
    let width = listed.min(max.max(1)).max(1);
    (width, listed.div_ceil(width))
}

/// What a dispatch over photon buffer `photons` uses: bindings 0–13 of `photon_tiles.comp`
/// (the fourth target, unused at full resolution, is the third again). `read`: whether the
/// dispatch reads the buffer's photons (buffer 0 is dispatched without any, to clear the
/// targets, and may then belong to another queue).
fn gather_uses<'a>(
    inputs: &PhotonVolumeInputs<'a>,
    (photons, read): (&'a Buffer, bool),
    (offsets, indices, spheres): (&'a Buffer, &'a Buffer, &'a Buffer),
    targets: &[&'a Image],
    sampler: &'a Sampler,
) -> Vec<Use<'a>> {
    let g = inputs.gbuffer;
    let mut uses = vec![
        Use::Uniform(inputs.frame),
        if read {
            Use::Read(photons)
        } else {
            Use::Bound(photons)
        },
        Use::Read(inputs.materials),
        Use::Sampled(&g.position, sampler),
        Use::Sampled(&g.normal, sampler),
        Use::Sampled(&g.albedo, sampler),
        Use::Sampled(&g.material, sampler),
        Use::Read(offsets),
        Use::Read(indices),
    ];
    for i in 0..4 {
        uses.push(Use::Storage(targets[i.min(targets.len() - 1)]));
    }
    uses.push(Use::Read(spheres));
    uses
}

#[cfg(test)]
mod tests {
    use super::rows_of;

    #[test]
    fn the_fine_dispatch_covers_every_listed_tile_within_the_device_limit() {
        for (listed, max) in [
            (1, 65_535),
            (4800, 65_535),
            (65_535, 65_535),
            (129_600, 65_535),
        ]
        .into_iter()
        .chain([(0, 7), (1, 7), (7, 7), (8, 7), (48, 7), (49, 7)])
        {
            let (x, y) = rows_of(listed, max);
            // (Rows are limited too, to at least 65 535: any screen's tiles fit.)
            assert!(x <= max && y <= max, "{listed} tiles, max {max}: {x} × {y}");
            // Every listed tile has a workgroup, and less than a row is left over.
            assert!(x * y >= listed, "{listed}, {max}: {x} × {y}");
            assert!(
                x * y < listed + x || listed == 0,
                "{listed}, {max}: {x} × {y}"
            );
        }
        assert_eq!(rows_of(129_600, 65_535), (65_535, 2));
        assert_eq!(rows_of(4800, 65_535), (4800, 1));
    }
}
