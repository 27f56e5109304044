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

use crate::layout::shared_constants::PHOTON_TILE;
use crate::passes::photon_volumes::billboard_half_size;
use crate::photon::kernel::{kernel_radius, KernelSettings};
use crate::photon::types::{unpack_normal, Photon};
use glam::{Mat4, Vec3, Vec4};

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

/// Lists the drawn photons (`photons`: positions relative to the photon map's origin, normals
/// packed with their kNN radii, in photon-map order, `counts[b]` of them in buffer b) in the
/// tiles of `screen` their kernels (`kernel`, after `offset` = origin − eye is added) may reach.
pub fn bin(
    photons: impl Iterator<Item = Photon>,
    counts: &[u32],
    (kernel, offset): (&KernelSettings, Vec3),
    screen: &Screen,
) -> TileLists {
    let (columns, rows) = screen.tiles();
    let tiles = (columns * rows) as usize;
    // Each kept photon's buffer, index in it and tile rectangle.
    let mut rects: Vec<(u32, u32, [u32; 4])> = Vec::new();
    let mut buffers = counts
        .iter()
        .enumerate()
        .flat_map(|(b, &n)| (0..n).map(move |i| (b as u32, i)));
    let mut spheres = Vec::with_capacity(counts.iter().map(|&n| n as usize).sum());
    for photon in photons {
        let Some((b, i)) = buffers.next() else {
            break;
        };
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
            rects.push((b, i, [x0 / t, y0 / t, x1 / t, y1 / t]));
        }
    }
    let area = |r: &[u32; 4]| ((r[2] - r[0] + 1) * (r[3] - r[1] + 1)) as usize;
    let stride = tiles + 1;
    let mut offsets = vec![0u32; counts.len().max(1) * stride];
    for (b, _, rect) in &rects {
        for y in rect[1]..=rect[3] {
            for x in rect[0]..=rect[2] {
                offsets[*b as usize * stride + (y * columns + x) as usize + 1] += 1;
            }
        }
    }
    // Exclusive prefix sum over every buffer's tiles in turn; each buffer's last entry is the
    // next one's first (so every buffer's tiles + 1 offsets are complete).
    let mut total = 0u32;
    for b in 0..counts.len().max(1) {
        let row = &mut offsets[b * stride..(b + 1) * stride];
        row[0] = total;
        for entry in &mut row[1..] {
            total += *entry;
            *entry = total;
        }
    }
    debug_assert_eq!(
        total as usize,
        rects.iter().map(|r| area(&r.2)).sum::<usize>()
    );
    let mut cursor: Vec<u32> = offsets.clone();
    let mut indices = vec![0u32; total as usize];
    for (b, i, rect) in &rects {
        for y in rect[1]..=rect[3] {
            for x in rect[0]..=rect[2] {
                let slot = &mut cursor[*b as usize * stride + (y * columns + x) as usize];
                indices[*slot as usize] = *i;
                *slot += 1;
            }
        }
    }
    TileLists {
        columns,
        rows,
        offsets,
        indices,
        spheres,
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
                photons.iter().copied(),
                &counts,
                (&kernel, Vec3::ZERO),
                &screen,
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
        let lists = bin(photons.into_iter(), &[3, 2], (&kernel, Vec3::ZERO), &screen);
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
    fn a_sphere_around_the_eye_is_listed_everywhere() {
        let screen = screen(2);
        assert_eq!(
            screen.pixels(Vec3::new(0.0, 0.0, -0.5), 1.0),
            Some([0, 0, 79, 59])
        );
        assert_eq!(screen.pixels(Vec3::new(0.0, 0.0, 5.0), 1.0), None, "behind");
    }
}
