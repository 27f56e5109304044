//! The tiled estimator's photon lists (`--density tiled`, `passes/photon_tiles.rs`): each
//! photon of the drawn map is listed in every screen tile its kernel's bounding sphere may
//! cover, on the CPU, once per frame (the lists depend on the eye, the map does not).
//!
//! ```text
//!   photon (centre c, radius r)        the photon volumes' billboard of the sphere: a square
//!        ┌───────┐                     at its far side, perpendicular to the eye ray, that
//!        │ ( ● ) │ ──view_proj──►      covers the sphere's projection (photon_volumes.rs),
//!        └───────┘                     clipped to w > 0 and projected; its pixel rectangle,
//!                                      widened by a pixel, gives the tiles
//!   ┌────┬────┬────┬────┐
//!   │    │ ▓▓ │ ▓▓ │    │  tiles of PHOTON_TILE² target pixels: the photon is listed in ▓
//!   ├────┼────┼────┼────┤
//!   │    │ ▓▓ │ ▓▓ │    │  offsets[b·(tiles+1) + t] .. offsets[b·(tiles+1) + t + 1]: where
//!   └────┴────┴────┴────┘  tile t's photons of photon buffer b lie in `indices`
//! ```
//!
//! The list is conservative: a listed photon may miss every pixel of the tile (the shader's
//! kernel test decides), but a photon that reaches a pixel is always listed in its tile, so the
//! gathered sum is the photon volumes' sum. Photons without power or with a broken position are
//! left out, as the volumes' vertex stage collapses them. At `--subsample N > 1` the target
//! pixels are the low-resolution ones, each shading the G-buffer pixel at the centre of its N×N
//! block.
//!
//! # In parallel
//! [`bin`] works in three steps, each split over threads where it is given more than one:
//!
//! ```text
//!   1. runs of the map ──► per photon: sphere; its tile rectangle into the bucket of each band
//!                          of tile rows it reaches                 (each run in map order)
//!   2. bands of tile rows ──► each band counts its tiles' entries  (its buckets, run by run)
//!      prefix sum ──► offsets                                      (one thread: tiles × buffers)
//!   3. bands of tile rows ──► each band writes its tiles' lists    (its own share of `indices`)
//! ```
//!
//! A band reads its rectangles in map order and writes only its own rows: the lists do not
//! depend on the number of threads (tested), and every list is in map order. The renderer bins on
//! every core where the device has cores of its own, and on one thread on a CPU device
//! (lavapipe), whose "GPU" passes run on the cores the other threads would take
//! (docs/performance.md, "Where the frame goes").

use crate::layout::shared_constants::PHOTON_TILE;
use crate::passes::photon_volumes::billboard_half_size;
use crate::photon::kernel::{kernel_radius, KernelSettings};
use crate::photon::types::{unpack_normal, Photon};
use glam::{Mat4, Vec3, Vec4};
use rayon::prelude::*;
use std::ops::Range;

/// The host span (`timing::timed`) of binning the lists: `cpu.photon tiles` among `ispm
/// bench`'s stage times.
pub const SPAN: &str = "photon tiles";

/// Bounding spheres are binned this much larger than the shader's radius, against the
/// rounding between the CPU's and the GPU's arithmetic.
const RADIUS_MARGIN: f32 = 1.001;

/// The screen the lists are made for.
#[derive(Clone, Copy, Debug)]
pub struct Screen {
    /// Eye-relative world → clip (the frame's `view_proj`).
    pub view_proj: Mat4,
    /// The full-resolution image (the eye G-buffer's size).
    pub size: (u32, u32),
    /// The estimate's `--subsample` factor (1: full resolution).
    pub subsample: u32,
}

impl Screen {
    /// The size of the targets the estimate is made at.
    pub fn target(&self) -> (u32, u32) {
        crate::passes::upsample::low_size(self.size.0, self.size.1, self.subsample)
    }

    /// Tiles per row and per column.
    pub fn tiles(&self) -> (u32, u32) {
        let (w, h) = self.target();
        (w.div_ceil(PHOTON_TILE), h.div_ceil(PHOTON_TILE))
    }

    /// The inclusive rectangle of target pixels `[x0, y0, x1, y1]` whose shaded G-buffer pixel
    /// may lie inside the sphere of radius `r` around the eye-relative `centre`, or `None` when
    /// no pixel's can (behind the eye, off screen).
    pub fn pixels(&self, centre: Vec3, r: f32) -> Option<[u32; 4]> {
        let (tw, th) = self.target();
        let (w, h) = (self.size.0 as f32, self.size.1 as f32);
        let all = [0, 0, tw.saturating_sub(1), th.saturating_sub(1)];
        let d = centre.length();
        let Some(half) = billboard_half_size(d, r) else {
            return Some(all); // the eye inside the sphere: the whole screen
        };
        // The billboard's corners (any square perpendicular to the eye ray covers it).
        let dir = centre / d;
        let (t, b) = dir.any_orthonormal_pair();
        let far = dir * (d + r);
        let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .map(|(u, v)| self.view_proj * (far + (t * u + b * v) * half).extend(1.0));
        // Clipped to w ≥ ε (Sutherland–Hodgman, one plane): the part behind the eye projects
        // nowhere, the part just in front of it far off screen.
        const EPS: f32 = 1e-6;
        let mut lo = glam::Vec2::splat(f32::INFINITY);
        let mut hi = glam::Vec2::splat(f32::NEG_INFINITY);
        let mut any = false;
        let mut project = |p: Vec4| {
            let ndc = glam::Vec2::new(p.x, p.y) / p.w;
            let px = (ndc * 0.5 + 0.5) * glam::Vec2::new(w, h);
            lo = lo.min(px);
            hi = hi.max(px);
            any = true;
        };
        for i in 0..4 {
            let (a, b) = (corners[i], corners[(i + 1) % 4]);
            if a.w >= EPS {
                project(a);
            }
            if (a.w >= EPS) != (b.w >= EPS) {
                let s = (EPS - a.w) / (b.w - a.w);
                project(a + (b - a) * s);
            }
        }
        if !any || lo.is_nan() || hi.is_nan() {
            return None;
        }
        // Full-resolution pixels whose centre p + ½ may lie in [lo, hi], a pixel wider.
        let clamp = |v: f32| v.clamp(-1.0e7, 1.0e7).floor() as i64;
        let (x0, y0) = (clamp(lo.x) - 1, clamp(lo.y) - 1);
        let (x1, y1) = (clamp(hi.x) + 1, clamp(hi.y) + 1);
        // Target pixel i shades min(i·N + N/2, size − 1), which is nondecreasing in i: it lies
        // in [x0, x1] only for i in [⌊(x0 − N)/N⌋, ⌊x1/N⌋].
        let n = i64::from(self.subsample.max(1));
        let range = |a: i64, b: i64, size: u32| {
            let (i0, i1) = ((a - n).div_euclid(n), b.div_euclid(n));
            let last = i64::from(size) - 1;
            (i1 >= 0 && i0 <= last).then(|| (i0.max(0) as u32, i1.min(last) as u32))
        };
        let (xa, xb) = range(x0, x1, tw)?;
        let (ya, yb) = range(y0, y1, th)?;
        Some([xa, ya, xb, yb])
    }
}

/// Per tile and photon buffer, the photons to gather (module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TileLists {
    pub columns: u32,
    pub rows: u32,
    /// `buffers × (tiles + 1)` entries: buffer b's tile t lists
    /// `indices[offsets[b·(tiles+1) + t] .. offsets[b·(tiles+1) + t + 1]]`.
    pub offsets: Vec<u32>,
    /// Photon indices within their buffer.
    pub indices: Vec<u32>,
    /// Per photon of the map (photon-map order, every buffer's in turn): its kernel's bounding
    /// sphere, eye-relative centre and radius, a little wider than the shader's (w = 0 for a
    /// photon left out), which the shader culls against before it unpacks the photon.
    pub spheres: Vec<[f32; 4]>,
}

impl TileLists {
    pub fn tiles(&self) -> usize {
        (self.columns * self.rows) as usize
    }

    /// Where photon buffer `buffer`'s offsets begin.
    pub fn first(&self, buffer: usize) -> u32 {
        (buffer * (self.tiles() + 1)) as u32
    }

    /// The length of buffer `buffer`'s longest tile list (0 for a buffer without lists).
    pub fn longest(&self, buffer: usize) -> usize {
        let first = self.first(buffer) as usize;
        self.offsets
            .get(first..=first + self.tiles())
            .map_or(0, |o| {
                o.windows(2)
                    .map(|w| (w[1] - w[0]) as usize)
                    .max()
                    .unwrap_or(0)
            })
    }

    /// The photons of tile `tile` from buffer `buffer`.
    pub fn list(&self, buffer: usize, tile: usize) -> &[u32] {
        let first = self.first(buffer) as usize + tile;
        &self.indices[self.offsets[first] as usize..self.offsets[first + 1] as usize]
    }
}

/// A kept photon's buffer, index in it and inclusive tile rectangle `[x0, y0, x1, y1]`.
type Rect = (u32, u32, [u32; 4]);

/// `f` over `items`, in order: on the current rayon pool when `split` (the threads the work is
/// split for) is more than one, else on the calling thread.
fn map_in_order<T: Send, R: Send>(
    items: Vec<T>,
    split: usize,
    f: impl Fn(T) -> R + Sync + Send,
) -> Vec<R> {
    if split > 1 {
        items.into_par_iter().map(f).collect()
    } else {
        items.into_iter().map(f).collect()
    }
}

/// Lists the drawn photons in the tiles of `screen` their kernels (`kernel`, after `offset` =
/// origin − eye is added) may reach. `photons(range)` yields the photons of the map's index
/// range `range` (positions relative to the photon map's origin, normals packed with their kNN
/// radii, in photon-map order), `counts[b]` of them in buffer b.
///
/// The work is split for `threads` threads and runs on the current rayon pool (on the calling
/// thread alone for one; module docs, "In parallel"); the lists are the same for any number.
pub fn bin<I: Iterator<Item = Photon>>(
    photons: impl Fn(Range<usize>) -> I + Sync,
    counts: &[u32],
    (kernel, offset): (&KernelSettings, Vec3),
    screen: &Screen,
    threads: usize,
) -> TileLists {
    let (columns, rows) = screen.tiles();
    let tiles = (columns * rows) as usize;
    let buffers = counts.len().max(1);
    let stride = tiles + 1;
    // Where each buffer's photons begin in the map.
    let firsts: Vec<usize> = counts
        .iter()
        .scan(0usize, |at, &n| {
            let first = *at;
            *at += n as usize;
            Some(first)
        })
        .collect();
    let total = counts.iter().map(|&n| n as usize).sum::<usize>();
    // Bands of tile rows: each counts and writes its own tiles' lists (steps 2 and 3).
    let band_rows = rows
        .div_ceil(if threads > 1 { threads as u32 * 4 } else { 1 })
        .max(1);
    let bands: Vec<(u32, u32)> = (0..rows)
        .step_by(band_rows as usize)
        .map(|r0| (r0, (r0 + band_rows).min(rows)))
        .collect();

    // 1. Each photon's bounding sphere, and its tile rectangle in the bucket of every band it
    // reaches: runs of the map, each in map order.
    let run = total
        .div_ceil(if threads > 1 { threads * 4 } else { 1 })
        .max(1);
    let runs: Vec<usize> = (0..total).step_by(run).collect();
    type Part = (Vec<[f32; 4]>, Vec<Vec<Rect>>);
    let parts: Vec<Part> = map_in_order(runs, threads, |start| {
        let range = start..(start + run).min(total);
        let mut spheres = Vec::with_capacity(range.len());
        let mut buckets: Vec<Vec<Rect>> = vec![Vec::new(); bands.len()];
        for (k, photon) in range.clone().zip(photons(range)) {
            let b = firsts.partition_point(|&f| f <= k) - 1;
            let i = (k - firsts[b]) as u32;
            let centre = photon.position + offset;
            if !photon.power.cmpgt(Vec3::ZERO).any() || !centre.is_finite() {
                spheres.push([0.0; 4]);
                continue;
            }
            let (_, r_knn) = unpack_normal(photon.normal);
            let (r, _) = kernel_radius(r_knn, kernel, centre.length());
            let r = r * RADIUS_MARGIN;
            spheres.push(centre.extend(r).to_array());
            if let Some([x0, y0, x1, y1]) = screen.pixels(centre, r) {
                let t = PHOTON_TILE;
                let rect = [x0 / t, y0 / t, x1 / t, y1 / t];
                for bucket in
                    &mut buckets[(rect[1] / band_rows) as usize..=(rect[3] / band_rows) as usize]
                {
                    bucket.push((b as u32, i, rect));
                }
            }
        }
        (spheres, buckets)
    });
    // Band `band`'s rectangles, in map order.
    let rects = |band: usize| parts.iter().flat_map(move |(_, buckets)| &buckets[band]);

    // 2. Each band counts its tiles' entries. The part of `rect` in rows `r0..r1`, as tile
    // indices relative to the band's first tile:
    let band_tiles = move |rect: [u32; 4], (r0, r1): (u32, u32)| {
        (rect[1].max(r0)..=rect[3].min(r1 - 1))
            .flat_map(move |y| (rect[0]..=rect[2]).map(move |x| ((y - r0) * columns + x) as usize))
    };
    let jobs: Vec<(usize, (u32, u32))> = bands.iter().copied().enumerate().collect();
    let band_counts = map_in_order(jobs, threads, |(index, band)| {
        let size = ((band.1 - band.0) * columns) as usize;
        let mut count = vec![0u32; buffers * size];
        for (b, _, rect) in rects(index) {
            for t in band_tiles(*rect, band) {
                count[*b as usize * size + t] += 1;
            }
        }
        count
    });
    let mut offsets = vec![0u32; buffers * stride];
    for (&(r0, r1), count) in bands.iter().zip(&band_counts) {
        let (first, size) = ((r0 * columns) as usize, ((r1 - r0) * columns) as usize);
        for b in 0..buffers {
            offsets[b * stride + first + 1..][..size].copy_from_slice(&count[b * size..][..size]);
        }
    }
    // Exclusive prefix sum over every buffer's tiles in turn; each buffer's last entry is the
    // next one's first (so every buffer's tiles + 1 offsets are complete).
    let mut sum = 0u32;
    for b in 0..buffers {
        let row = &mut offsets[b * stride..(b + 1) * stride];
        row[0] = sum;
        for entry in &mut row[1..] {
            sum += *entry;
            *entry = sum;
        }
    }
    // Every rectangle's tiles, band by band.
    debug_assert_eq!(
        sum as usize,
        (bands.iter().enumerate())
            .flat_map(|(index, &band)| rects(index).map(move |rect| (band, rect)))
            .map(|(band, (_, _, rect))| band_tiles(*rect, band).count())
            .sum::<usize>()
    );
    // 3. Each band's share of `indices`, per buffer: one range, as buffer b's lists are its
    // tiles' in row order.
    let mut indices = vec![0u32; sum as usize];
    let mut shares: Vec<Vec<&mut [u32]>> = bands.iter().map(|_| Vec::new()).collect();
    let mut rest = &mut indices[..];
    for b in 0..buffers {
        for (share, &(r0, r1)) in shares.iter_mut().zip(&bands) {
            let at = |row: u32| offsets[b * stride + (row * columns) as usize] as usize;
            let (mine, after) = std::mem::take(&mut rest).split_at_mut(at(r1) - at(r0));
            share.push(mine);
            rest = after;
        }
    }
    let jobs: Vec<_> = bands.iter().copied().enumerate().zip(shares).collect();
    map_in_order(jobs, threads, |((index, band), mut share)| {
        let first = (band.0 * columns) as usize;
        let size = ((band.1 - band.0) * columns) as usize;
        // Per buffer and tile of the band, the next free slot of its list in the share.
        let mut cursor: Vec<u32> = (0..buffers)
            .flat_map(|b| {
                let base = offsets[b * stride + first];
                offsets[b * stride + first..][..size]
                    .iter()
                    .map(move |&o| o - base)
            })
            .collect();
        for (b, i, rect) in rects(index) {
            let b = *b as usize;
            for t in band_tiles(*rect, band) {
                let slot = &mut cursor[b * size + t];
                share[b][*slot as usize] = *i;
                *slot += 1;
            }
        }
    });
    TileLists {
        columns,
        rows,
        offsets,
        indices,
        spheres: parts.into_iter().flat_map(|(spheres, _)| spheres).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::types::pack_normal;

    fn screen(subsample: u32) -> Screen {
        let proj =
            glam::camera::rh::proj::vulkan::perspective_infinite_reverse(1.0, 4.0 / 3.0, 0.05);
        let view = glam::camera::rh::view::look_to_mat4(
            Vec3::ZERO,
            Vec3::new(0.1, -0.2, -1.0).normalize(),
            Vec3::Y,
        );
        Screen {
            view_proj: proj * view,
            size: (160, 120),
            subsample,
        }
    }

    /// The target pixel whose shaded G-buffer pixel sees the eye-relative point `p`.
    fn pixel_of(screen: &Screen, p: Vec3) -> Option<(u32, u32)> {
        let clip = screen.view_proj * p.extend(1.0);
        if clip.w <= 0.0 {
            return None;
        }
        let (w, h) = screen.size;
        let x = ((clip.x / clip.w * 0.5 + 0.5) * w as f32).floor();
        let y = ((clip.y / clip.w * 0.5 + 0.5) * h as f32).floor();
        if x < 0.0 || y < 0.0 || x >= w as f32 || y >= h as f32 {
            return None;
        }
        let n = screen.subsample;
        let (tw, th) = screen.target();
        // The target pixels shading this G-buffer pixel (at most one per axis).
        let find =
            |g: u32, size: u32, full: u32| (0..size).find(|&i| (i * n + n / 2).min(full - 1) == g);
        Some((find(x as u32, tw, w)?, find(y as u32, th, h)?))
    }

    #[test]
    fn a_photon_is_listed_in_the_tile_of_every_pixel_its_kernel_reaches() {
        let kernel = KernelSettings {
            r_min: 0.001,
            r_max: 10.0,
            scale: 1.0,
            footprint: 0.0,
            footprint_max: 10.0,
        };
        let mut rng = crate::photon::rng::Rng::new(7);
        for subsample in [1, 2, 3] {
            let screen = screen(subsample);
            let (columns, _) = screen.tiles();
            let mut photons = Vec::new();
            // Near and far, small and large, some straddling the eye plane or around the eye.
            for k in 0..60 {
                let dir = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, -rng.next_f32())
                    .normalize_or(Vec3::NEG_Z);
                let d = [0.3, 1.0, 3.0, 10.0][k % 4] * (0.2 + rng.next_f32());
                let r = [0.02, 0.2, 1.0][k % 3] * d;
                photons.push(Photon {
                    power: Vec3::ONE,
                    direction: Vec3::Y,
                    position: dir * d,
                    normal: pack_normal(Vec3::Y, r),
                });
            }
            let counts = [photons.len() as u32];
            let lists = bin(
                |r| photons[r].iter().copied(),
                &counts,
                (&kernel, Vec3::ZERO),
                &screen,
                1,
            );
            let mut hits = 0;
            for (i, p) in photons.iter().enumerate() {
                let (_, r) = unpack_normal(p.normal);
                // Points inside the sphere: every pixel they project to lists the photon.
                for _ in 0..1500 {
                    let u = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
                    if u.length() > 1.0 {
                        continue;
                    }
                    let q = p.position + u * r * 0.999;
                    let Some((x, y)) = pixel_of(&screen, q) else {
                        continue;
                    };
                    let tile = ((y / PHOTON_TILE) * columns + x / PHOTON_TILE) as usize;
                    assert!(
                        lists.list(0, tile).contains(&(i as u32)),
                        "subsample {subsample}: photon {i} (at {}, r {r}) reaches pixel \
                         ({x}, {y}) but is not listed in tile {tile}",
                        p.position
                    );
                    hits += 1;
                }
            }
            assert!(hits > 1000, "subsample {subsample}: {hits} points checked");
        }
    }

    #[test]
    fn lists_are_per_buffer_and_skip_photons_without_power() {
        let kernel = KernelSettings {
            r_min: 0.001,
            r_max: 1.0,
            scale: 1.0,
            footprint: 0.0,
            footprint_max: 1.0,
        };
        let photon = |z: f32, power: f32| Photon {
            power: Vec3::splat(power),
            direction: Vec3::Y,
            position: Vec3::new(0.0, 0.0, z),
            normal: pack_normal(Vec3::Z, 0.05),
        };
        // In view, without power, behind the eye; in view (buffer 1), a broken position.
        let photons = [
            photon(-2.0, 1.0),
            photon(-2.0, 0.0),
            photon(2.0, 1.0),
            photon(-3.0, 1.0),
            photon(f32::NAN, 1.0),
        ];
        let screen = screen(1);
        let lists = bin(
            |r| photons[r].iter().copied(),
            &[3, 2],
            (&kernel, Vec3::ZERO),
            &screen,
            1,
        );
        let tiles = lists.tiles();
        assert_eq!(lists.offsets.len(), 2 * (tiles + 1));
        assert!(lists.offsets.windows(2).all(|w| w[0] <= w[1]));
        let listed = |b: usize| -> Vec<u32> {
            let mut all: Vec<u32> = (0..tiles).flat_map(|t| lists.list(b, t).to_vec()).collect();
            all.sort_unstable();
            all.dedup();
            all
        };
        assert_eq!(listed(0), vec![0], "buffer 0: only the lit photon in view");
        assert_eq!(
            listed(1),
            vec![0],
            "buffer 1: its first photon, by its index there"
        );
        assert_eq!(*lists.offsets.last().unwrap() as usize, lists.indices.len());
    }

    #[test]
    fn the_lists_are_the_same_on_any_number_of_threads_and_in_map_order() {
        let kernel = KernelSettings {
            r_min: 0.001,
            r_max: 2.0,
            scale: 1.0,
            footprint: 0.0,
            footprint_max: 2.0,
        };
        let mut rng = crate::photon::rng::Rng::new(11);
        let photons: Vec<Photon> = (0..5000)
            .map(|k| Photon {
                power: Vec3::splat(if k % 17 == 0 { 0.0 } else { 1.0 }),
                direction: Vec3::Y,
                position: Vec3::new(
                    rng.next_f32() * 8.0 - 4.0,
                    rng.next_f32() * 6.0 - 3.0,
                    -0.5 - rng.next_f32() * 6.0,
                ),
                normal: pack_normal(Vec3::Y, 0.01 + rng.next_f32() * 0.5),
            })
            .collect();
        // Four buffers, one of them empty; the last shorter than the rest.
        let counts = [2000, 0, 1800, 1200];
        for subsample in [1, 2] {
            let screen = screen(subsample);
            let lists = |threads| {
                bin(
                    |r| photons[r].iter().copied(),
                    &counts,
                    (&kernel, Vec3::new(0.1, 0.0, 0.0)),
                    &screen,
                    threads,
                )
            };
            let one = lists(1);
            assert!(one.indices.len() > photons.len(), "{}", one.indices.len());
            for b in 0..counts.len() {
                for t in 0..one.tiles() {
                    let list = one.list(b, t);
                    assert!(list.windows(2).all(|w| w[0] < w[1]), "buffer {b} tile {t}");
                }
            }
            for threads in [2, 3, 8, 64] {
                assert!(
                    lists(threads) == one,
                    "subsample {subsample}: {threads} threads differ from one"
                );
            }
        }
    }

    #[test]
    fn a_sphere_around_the_eye_is_listed_everywhere() {
        let screen = screen(2);
        assert_eq!(
            screen.pixels(Vec3::new(0.0, 0.0, -0.5), 1.0),
            Some([0, 0, 79, 59])
        );
        assert_eq!(screen.pixels(Vec3::new(0.0, 0.0, 5.0), 1.0), None, "behind");
    }
}
