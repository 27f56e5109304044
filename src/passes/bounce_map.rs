//! Bounce map (compute): the first bounce of every photon, one per light G-buffer texel, in
//! the record layout of DESIGN.md §2.1 (`photon::types::BounceMapPhoton`, 32 bytes). The map
//! is then copied to a host-visible buffer for the CPU trace.
//!
//! The map may be split over several buffers (hard case "more photons than fit in one
//! buffer", docs/stability.md): a storage buffer is read through one descriptor, which reaches
//! `maxStorageBufferRange` bytes at most (128 MiB on lavapipe: 4.2 M records). Record `i` of
//! the map is record `i − base` of buffer `i / per_buffer` ([`Split`]); the pass has one
//! descriptor set per buffer and one dispatch per [`ViewBatch`], each batch's records in one
//! buffer:
//!
//! ```text
//!   records  0 ……………………………………………………………………………………………………………… texels
//!   views    |── view 0 ──|──── view 1 ────|── view 2 ──|
//!   buffers  |──── buffer 0 ────|──── buffer 1 ────| 2 ─|
//!   batches  |──── 0 ─────|─ 1 ─|─── 1 ────|── 2 ──| 2 ─|  (a view a buffer cuts: its rows in
//!                                                           each buffer, a batch of its own)
//! ```

use super::eye_gbuffer::GBuffer;
use super::ComputeKernel;
use crate::gpu::{Buffer, Cmd, Filter, Gpu, Sampler, Shaders, Use};
use crate::photon::bsdf::BsdfVariant;
use crate::photon::types::BounceMapPhoton;
use crate::timing::pass_id::PassId;
use std::ops::Range;
use std::sync::Arc;

/// Most buffers a bounce map is split over (64 × 128 MiB on lavapipe: 268 M records).
pub const MAX_BOUNCE_BUFFERS: usize = 64;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    seed: u32,
    /// The first view of the dispatch (`gl_GlobalInvocationID.z` counts from it).
    first_view: u32,
    /// The records the dispatch writes (map indices `first_record..first_record + records`),
    /// and the map index of the bound buffer's first record.
    first_record: u32,
    records: u32,
    base: u32,
    /// The first row of the views' texels the dispatch covers (`gl_GlobalInvocationID.y`
    /// counts from it).
    first_row: u32,
    /// The frame's photon sample: where in its texel each photon passes
    /// (`bounce_plan::texel_jitter`).
    sample: u32,
    pad: u32,
}

/// How a bounce map of `records` records is split over buffers of `per_buffer` records each:
/// record `i` of the map is record `i % per_buffer` of buffer `i / per_buffer`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Split {
    pub records: usize,
    pub per_buffer: usize,
}

impl Split {
    /// `records` records over buffers of the most records one storage buffer reaches,
    /// `range` bytes.
    pub fn new(records: usize, range: u64) -> Self {
        let per_buffer = (range / size_of::<BounceMapPhoton>() as u64).max(1);
        Self {
            records,
            per_buffer: usize::try_from(per_buffer).unwrap_or(usize::MAX),
        }
    }

    /// Buffers the map spans (at least one).
    pub fn buffers(self) -> usize {
        self.records.div_ceil(self.per_buffer).max(1)
    }

    /// The map indices of buffer `buffer`'s records.
    pub fn records_of(self, buffer: usize) -> Range<usize> {
        let start = (buffer * self.per_buffer).min(self.records);
        start..(start + self.per_buffer).min(self.records)
    }

    /// `records` (map indices, within the map) cut where buffers end: (buffer, its part of
    /// `records`), in order, empty parts left out.
    pub fn pieces(self, records: Range<usize>) -> impl Iterator<Item = (usize, Range<usize>)> {
        assert!(
            records.is_empty() || records.end <= self.records,
            "records {records:?} past the end of a map of {}",
            self.records
        );
        let buffers = if records.is_empty() {
            0..0
        } else {
            records.start / self.per_buffer..(records.end - 1) / self.per_buffer + 1
        };
        buffers.map(move |b| {
            let own = self.records_of(b);
            (b, own.start.max(records.start)..own.end.min(records.end))
        })
    }
}

/// Consecutive views the bounce map is made for in one dispatch: rows `first_row..` of views
/// `first..first + count`, `extent` = (width, rows) texels at most, writing their records
/// `records` (map indices), which lie in one buffer of the map. `first_row` is 0 but for a
/// view cut by a buffer's end, which gets a batch of its own.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ViewBatch {
    pub first: u32,
    pub count: u32,
    pub first_row: u32,
    pub extent: (u32, u32),
    pub records: Range<usize>,
}

impl ViewBatch {
    /// The batches making the records of views `views` of a plan, with `view_records(v)` the
    /// records of view `v` and `extent(v)` its texels, split as `split` says: per buffer the
    /// views' records touch, one batch for each run of views whose records all lie in it, and
    /// one for each view cut by the buffer's ends, of its rows in the buffer only (so that no
    /// dispatch runs over texels another buffer holds but for the rows a cut passes through).
    pub fn split(
        views: Range<usize>,
        view_records: impl Fn(usize) -> Range<usize>,
        extent: impl Fn(usize) -> (u32, u32),
        split: Split,
    ) -> Vec<ViewBatch> {
        if views.is_empty() {
            return Vec::new();
        }
        let all = view_records(views.start).start..view_records(views.end - 1).end;
        let mut batches = Vec::new();
        for (_, piece) in split.pieces(all) {
            // The views with records in the piece (views without texels have none).
            let meets = views.clone().filter(|&v| {
                let r = view_records(v);
                !r.is_empty() && r.start < piece.end && r.end > piece.start
            });
            let mut run: Option<ViewBatch> = None;
            for v in meets {
                let (r, (w, h)) = (view_records(v), extent(v));
                let part = r.start.max(piece.start)..r.end.min(piece.end);
                if part == r {
                    // Whole: joins the run of whole views.
                    match &mut run {
                        Some(b) => {
                            // Over any empty views in between (they write nothing).
                            b.count = v as u32 + 1 - b.first;
                            b.extent = (b.extent.0.max(w), b.extent.1.max(h));
                            b.records.end = part.end;
                        }
                        None => {
                            run = Some(ViewBatch {
                                first: v as u32,
                                count: 1,
                                first_row: 0,
                                extent: (w, h),
                                records: part,
                            })
                        }
                    }
                    continue;
                }
                // Cut by the piece's ends: its own batch, of the rows holding the part.
                batches.extend(run.take());
                let width = w.max(1) as usize;
                let rows = (part.start - r.start) / width..(part.end - r.start).div_ceil(width);
                batches.push(ViewBatch {
                    first: v as u32,
                    count: 1,
                    first_row: rows.start as u32,
                    extent: (w, rows.len() as u32),
                    records: part,
                });
            }
            batches.extend(run);
        }
        batches
    }
}

pub struct BounceMapPass {
    kernel: ComputeKernel,
    sampler: Sampler,
}

/// What the bounce map reads and writes.
pub struct BounceMapIo<'a> {
    pub materials: &'a Buffer,
    pub views: &'a Buffer,
    pub light_gbuffer: &'a GBuffer,
    /// `BounceMapPhoton[texels]`, device-local, over one or more buffers as `split` says.
    pub bounce_map: &'a [Buffer],
    pub split: Split,
}

impl BounceMapPass {
    /// The pass with the über-BSDF lobes of `variant` compiled in.
    pub fn new(gpu: &Arc<Gpu>, io: &BounceMapIo, variant: BsdfVariant) -> anyhow::Result<Self> {
        let sampler = Sampler::new(gpu, "bounce_map.nearest", Filter::Nearest, false)?;
        // One set per buffer of the map, the same but for the last binding.
        let sets: Vec<[Use; 7]> = (0..io.bounce_map.len())
            .map(|b| Self::uses(io, b, &sampler))
            .collect();
        let sets: Vec<&[Use]> = sets.iter().map(|s| s.as_slice()).collect();
        let kernel = ComputeKernel::with_sets(
            gpu,
            PassId::BounceMap.name(),
            &crate::gpu::shader_table::BOUNCE_MAP_COMP,
            size_of::<Push>() as u32,
            &sets,
            &super::bsdf_constants(variant),
        )?;
        Ok(Self { kernel, sampler })
    }

    /// What a dispatch over buffer `buffer` of the map uses, in the shader's binding order.
    fn uses<'a>(io: &BounceMapIo<'a>, buffer: usize, sampler: &'a Sampler) -> [Use<'a>; 7] {
        let g = io.light_gbuffer;
        [
            Use::Read(io.materials),
            Use::Read(io.views),
            Use::Sampled(&g.position, sampler),
            Use::Sampled(&g.normal, sampler),
            Use::Sampled(&g.albedo, sampler),
            Use::Sampled(&g.material, sampler),
            // Each dispatch writes its own records only, but binds a whole buffer: the
            // barrier orders the writes for synchronization validation.
            Use::Write(&io.bounce_map[buffer]),
        ]
    }

    /// Runs the first bounce over the views of `batches` (the others' records are left as
    /// they are: a frame that re-traces some lights only writes theirs).
    /// `seed` keys the first bounce's random numbers and `sample` the texels' jittered points.
    pub fn record(
        &self,
        cmd: &Cmd,
        io: &BounceMapIo,
        batches: &[ViewBatch],
        (seed, sample): (u32, u32),
    ) {
        let _scope = cmd.scope(PassId::BounceMap.name());
        for batch in batches
            .iter()
            .filter(|b| b.count > 0 && !b.records.is_empty())
        {
            let buffer = batch.records.start / io.split.per_buffer;
            cmd.uses(Shaders::Compute, &Self::uses(io, buffer, &self.sampler));
            let (w, h) = batch.extent;
            // Map indices fit in u32: the plan's views address records with u32 offsets.
            let push = Push {
                seed,
                first_view: batch.first,
                first_record: batch.records.start as u32,
                records: batch.records.len() as u32,
                base: io.split.records_of(buffer).start as u32,
                first_row: batch.first_row,
                sample,
                pad: 0,
            };
            let groups = [super::groups(w), super::groups(h), batch.count];
            self.kernel.dispatch_set_with(cmd, buffer, &push, groups);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pieces_cut_a_range_where_buffers_end_and_cover_it_once() {
        let split = Split {
            records: 25,
            per_buffer: 10,
        };
        assert_eq!(split.buffers(), 3);
        assert_eq!(split.records_of(2), 20..25);
        let pieces: Vec<_> = split.pieces(7..23).collect();
        assert_eq!(pieces, vec![(0, 7..10), (1, 10..20), (2, 20..23)]);
        assert_eq!(split.pieces(10..20).collect::<Vec<_>>(), vec![(1, 10..20)]);
        assert_eq!(split.pieces(4..4).count(), 0);
        // Every range of every map: pieces in order, each in its buffer, covering it once.
        for per_buffer in 1..7 {
            for records in 0..20 {
                let split = Split {
                    records,
                    per_buffer,
                };
                for start in 0..=records {
                    for end in start..=records {
                        let mut next = start;
                        for (b, piece) in split.pieces(start..end) {
                            assert_eq!(piece.start, next, "{split:?} {start}..{end}");
                            assert!(piece.end > piece.start);
                            let own = split.records_of(b);
                            assert!(own.start <= piece.start && piece.end <= own.end);
                            next = piece.end;
                        }
                        assert_eq!(next, end, "{split:?} {start}..{end}");
                    }
                }
            }
        }
    }

    /// The records of views of `sizes` texels laid out one after another from record `first`.
    fn laid_out(first: usize, sizes: &[(u32, u32)]) -> Vec<Range<usize>> {
        let mut at = first;
        let mut views = Vec::new();
        for &(w, h) in sizes {
            views.push(at..at + (w * h) as usize);
            at += (w * h) as usize;
        }
        views
    }

    /// A batch as (first, count, first_row, extent, records).
    type Batch = (u32, u32, u32, (u32, u32), Range<usize>);

    /// `ViewBatch::split` of views `range` of `sizes` laid out from record `first`, over a map
    /// of `records` records in buffers of `per_buffer`.
    fn batches(
        (first, sizes): (usize, &[(u32, u32)]),
        range: Range<usize>,
        (records, per_buffer): (usize, usize),
    ) -> Vec<Batch> {
        let views = laid_out(first, sizes);
        let split = Split {
            records,
            per_buffer,
        };
        ViewBatch::split(range, |v| views[v].clone(), |v| sizes[v], split)
            .into_iter()
            .map(|b| (b.first, b.count, b.first_row, b.extent, b.records))
            .collect()
    }

    #[test]
    fn view_batches_cover_every_record_once_in_the_buffer_holding_it() {
        // Views of assorted sizes (some empty) over buffers of assorted sizes: the texels the
        // batches' dispatches cover and keep (in their `records`) are each record exactly once.
        let sizes = [
            (3u32, 2u32),
            (0, 0),
            (4, 4),
            (1, 1),
            (0, 0),
            (5, 3),
            (2, 7),
            (1, 1),
        ];
        let views = laid_out(5, &sizes);
        let end = views[7].end;
        for per_buffer in 1..=end {
            for first in 0..8 {
                for last in first..=8 {
                    let mut seen = vec![0u32; end];
                    for (v0, count, row, extent, records) in
                        batches((5, &sizes), first..last, (end, per_buffer))
                    {
                        assert_eq!(records.start / per_buffer, (records.end - 1) / per_buffer);
                        for v in (v0..v0 + count).map(|v| v as usize) {
                            let (w, h) = sizes[v];
                            for y in row..(row + extent.1).min(h) {
                                for x in 0..w.min(extent.0) {
                                    let r = views[v].start + (y * w + x) as usize;
                                    if records.contains(&r) {
                                        seen[r] += 1;
                                    }
                                }
                            }
                        }
                    }
                    let want =
                        |r: usize| u32::from(views[first..last].iter().any(|v| v.contains(&r)));
                    for (r, &n) in seen.iter().enumerate() {
                        assert_eq!(
                            n,
                            want(r),
                            "record {r}, views {first}..{last}, {per_buffer}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn view_batches_hold_the_views_with_records_in_their_buffer() {
        // Views of 6, 0, 9 and 4 records in one row each (14..20, 20..20, 20..29, 29..33) over
        // buffers of 8: view 0 straddles buffers 1 and 2, view 2 buffers 2 and 3, view 3
        // buffers 3 and 4; the empty view 1 has no records and no batch. A cut view's batch is
        // its one row.
        let rows = [(6, 1), (0, 1), (9, 1), (4, 1)];
        assert_eq!(
            batches((14, &rows), 0..4, (40, 8)),
            vec![
                (0, 1, 0, (6, 1), 14..16),
                (0, 1, 0, (6, 1), 16..20),
                (2, 1, 0, (9, 1), 20..24),
                (2, 1, 0, (9, 1), 24..29),
                (3, 1, 0, (4, 1), 29..32),
                (3, 1, 0, (4, 1), 32..33),
            ]
        );
        assert!(batches((14, &rows), 2..2, (40, 8)).is_empty());
        // Views of 3×2, 4×4, 2×1 and 2×2 texels (records 0..6, 6..22, 22..24, 24..28) over
        // buffers of 10: view 1's rows 0–1 in buffer 0, rows 1–3 in buffer 1 (its row 1 in
        // both, each writing its own records); views 2 and 3 whole in buffer 2.
        let grids = [(3, 2), (4, 4), (2, 1), (2, 2)];
        assert_eq!(
            batches((0, &grids), 0..4, (28, 10)),
            vec![
                (0, 1, 0, (3, 2), 0..6),
                (1, 1, 0, (4, 1), 6..10),
                (1, 1, 1, (4, 3), 10..20),
                (1, 1, 3, (4, 1), 20..22),
                (2, 2, 0, (2, 2), 22..28),
            ]
        );
    }
}
