//! The tiled estimator's photon lists (`--density tiled`, `passes/photon_tiles.rs`): each
//! photon of the drawn map is listed in every screen tile its kernel's bounding sphere may
//! cover, on the CPU, once per frame (the lists depend on the eye, the map does not).
//!
//! ```text
//!   photon (centre c, radius r)        a sphere wholly in front of the eye projects onto an
//!          ╭───╮                       ellipse (`Ellipse`); each row of tiles lists the
//!         (  ●  ) ──view_proj──►       tiles of the ellipse's extent over that row's pixels
//!          ╰───╯                       (a pixel wider in x, half in y). A sphere that reaches
//!                                      the eye's plane takes the photon volumes' billboard (a
//!                                      square at its far side, clipped to w > 0:
//!                                      photon_volumes.rs), whose pixel rectangle, a pixel
//!                                      wider, gives the tiles
//!   ┌────┬────┬────┬────┐
//!   │    │ ▓▓ │ ▓▓ │    │  tiles of PHOTON_TILE² target pixels: the photon is listed in ▓
//!   ├────┼────┼────┼────┤
//!   │ ▓▓ │ ▓▓ │ ▓▓ │    │  offsets[b·(tiles+1) + t] .. offsets[b·(tiles+1) + t + 1]: where
//!   ├────┼────┼────┼────┤  tile t's photons of photon buffer b lie in `indices`
//!   │    │ ▓▓ │ ▓▓ │    │
//!   └────┴────┴────┴────┘
//! ```
//!
//! The shader reads every entry of a tile's list once per row of its pixels, so each entry
//! costs on lavapipe even where the photon reaches none of the tile's pixels: cutting the lists
//! from the billboard's rectangle (rotated with the eye ray, up to twice the projection's area)
//! to the ellipse's rows left 0.65× the entries on `glass-cube` and 0.79× on `cornell-box`
//! (docs/performance.md, "Lists cut to the ellipse").
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
//!   1. runs of the map ──► per photon: sphere; its tile rows (and each row's columns) into
//!                          the bucket of each band of tile rows it reaches
//!                                                                  (each run in map order)
//!   2. bands of tile rows ──► each band counts its tiles' entries  (its buckets, run by run)
//!      prefix sum ──► offsets                                      (one thread: tiles × buffers)
//!   3. bands of tile rows ──► each band writes its tiles' lists    (its own share of `indices`)
//! ```
//!
//! A band reads its photons' rows in map order and writes only its own rows: the lists do not
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
        let camera = Camera::new(&self.view_proj);
        self.projection(camera.as_ref(), centre, r)
            .map(|(rect, _)| rect)
    }

    /// [`Screen::pixels`]' rectangle, and the sphere's projection where it is an ellipse.
    /// `camera`: [`Camera::new`] of the view (`None`: no ellipses).
    fn projection(
        &self,
        camera: Option<&Camera>,
        centre: Vec3,
        r: f32,
    ) -> Option<([u32; 4], Option<Ellipse>)> {
        let (tw, th) = self.target();
        let (w, h) = (self.size.0 as f32, self.size.1 as f32);
        let all = [0, 0, tw.saturating_sub(1), th.saturating_sub(1)];
        // A sphere wholly in front of the eye projects onto an ellipse, whose extent is exact;
        // only one that reaches the eye's plane takes the billboard's.
        let ellipse = camera.and_then(|camera| Ellipse::new(camera, centre, r));
        let (lo, hi) = match &ellipse {
            Some(e) => {
                let px = |x: f64, y: f64| {
                    let v =
                        (glam::DVec2::new(x, y) * 0.5 + 0.5) * glam::DVec2::new(w.into(), h.into());
                    v.as_vec2()
                };
                (px(e.x.0, e.y.0), px(e.x.1, e.y.1))
            }
            None => {
                let d = centre.length();
                let Some(half) = billboard_half_size(d, r) else {
                    return Some((all, None)); // the eye inside the sphere: the whole screen
                };
                billboard_rect(&self.view_proj, (w, h), centre, (d, r, half))?
            }
        };
        if lo.is_nan() || hi.is_nan() {
            return None;
        }
        // Full-resolution pixels whose centre p + ½ may lie in [lo, hi], a pixel wider.
        let clamp = |v: f32| v.clamp(-1.0e7, 1.0e7).floor() as i64;
        let (x0, y0) = (clamp(lo.x) - 1, clamp(lo.y) - 1);
        let (x1, y1) = (clamp(hi.x) + 1, clamp(hi.y) + 1);
        let (xa, xb) = self.target_range(x0, x1, tw)?;
        let (ya, yb) = self.target_range(y0, y1, th)?;
        Some(([xa, ya, xb, yb], ellipse))
    }

    /// The target pixels (of `size` on the axis) whose shaded G-buffer pixel lies in the
    /// full-resolution pixels `a..=b`, if any. Target pixel i shades min(i·N + N/2, full − 1),
    /// which is nondecreasing in i: it lies in [a, b] only for i in [⌊(a − N)/N⌋, ⌊b/N⌋].
    fn target_range(&self, a: i64, b: i64, size: u32) -> Option<(u32, u32)> {
        let n = i64::from(self.subsample.max(1));
        let (i0, i1) = ((a - n).div_euclid(n), b.div_euclid(n));
        let last = i64::from(size) - 1;
        (i1 >= 0 && i0 <= last).then(|| (i0.max(0) as u32, i1.min(last) as u32))
    }

    /// The tile rows `y0..=y1` the sphere of radius `r` at the eye-relative `centre` may
    /// reach, or `None`; pushes onto `spans`, for each of those rows in turn, its tiles'
    /// inclusive column range (`[1, 0]`: none). `camera`: [`Camera::new`] of the view.
    ///
    /// [`Screen::pixels`]' rectangle, cut per row of tiles to the sphere's projection where
    /// that is an ellipse (the whole sphere in front of the eye): a large kernel's corner
    /// tiles are not listed.
    ///
    /// ```text
    ///   ┌──┬──┬──┬──┐   ┌──┬──┬──┬──┐
    ///   │▓▓│▓▓│▓▓│▓▓│   │  │▓▓│▓▓│  │   each row of tiles: the x extent of the ellipse over
    ///   ├──┼──┼──┼──┤   ├──┼──┼──┼──┤   the G-buffer rows of its pixels' blocks (N×N at
    ///   │▓▓│▓▓│▓▓│▓▓│ → │▓▓│▓▓│▓▓│▓▓│   --subsample N), whose shaded pixel centres lie at
    ///   ├──┼──┼──┼──┤   ├──┼──┼──┼──┤   least half a pixel inside; then a pixel wider
    ///   │▓▓│▓▓│▓▓│▓▓│   │  │▓▓│▓▓│  │   each way, as the rectangle
    ///   └──┴──┴──┴──┘   └──┴──┴──┴──┘
    /// ```
    fn tile_spans(
        &self,
        camera: Option<&Camera>,
        centre: Vec3,
        r: f32,
        spans: &mut Vec<[u32; 2]>,
    ) -> Option<(u32, u32)> {
        let ([x0, y0, x1, y1], ellipse) = self.projection(camera, centre, r)?;
        let t = PHOTON_TILE;
        let (rows, columns) = ((y0 / t, y1 / t), [x0 / t, x1 / t]);
        // One column of tiles: nothing to cut.
        let Some(ellipse) = ellipse.filter(|_| columns[0] < columns[1]) else {
            spans.extend((rows.0..=rows.1).map(|_| columns));
            return Some(rows);
        };
        let (w, h) = (f64::from(self.size.0), f64::from(self.size.1));
        let n = self.subsample.max(1);
        let target_width = self.target().0;
        // Row k of tiles covers the G-buffer rows [k·T·N, (k + 1)·T·N): each row's band shares
        // its ends, and their chords, with its neighbours.
        let edge = |k: u32| f64::from(k * t * n) / h * 2.0 - 1.0;
        let mut top = ellipse.clamped_chord(edge(rows.0));
        for row in rows.0..=rows.1 {
            let bottom = ellipse.clamped_chord(edge(row + 1));
            let band = (edge(row), edge(row + 1));
            let span = ellipse.x_range(band, (top, bottom)).and_then(|(a, b)| {
                // As the rectangle: the pixels whose centre may lie in [a, b], a pixel wider.
                let px = |x: f64| ((x * 0.5 + 0.5) * w).clamp(-1.0e7, 1.0e7).floor() as i64;
                let (xa, xb) = self.target_range(px(a) - 1, px(b) + 1, target_width)?;
                let (xa, xb) = (xa.max(x0), xb.min(x1));
                (xa <= xb).then_some([xa / t, xb / t])
            });
            spans.push(span.unwrap_or([1, 0]));
            top = bottom;
        }
        Some(rows)
    }
}

/// The eye-relative camera as [`Ellipse`] needs it, made once per list: with the eye at the
/// origin, the ray through the NDC point (a, b) is where the planes (row₀ − a row₃)·X = 0
/// and (row₁ − b row₃)·X = 0 meet, D(a, b) = K + a U + b V with K = n₀×n₁, U = n₁×n₃,
/// V = n₃×n₀ (n: the rows' xyz), affine in a and b.
struct Camera {
    n3: glam::DVec3,
    n3_length: f64,
    k: glam::DVec3,
    u: glam::DVec3,
    v: glam::DVec3,
    /// K·K, U·U, V·V, K·U, K·V, U·V.
    dots: [f64; 6],
}

impl Camera {
    /// `None` unless the eye is at the origin of `view_proj`'s space.
    fn new(view_proj: &Mat4) -> Option<Self> {
        let rows = [0, 1, 3].map(|i| view_proj.row(i).as_dvec4());
        let scale = rows
            .iter()
            .map(|row| row.truncate().length())
            .fold(0.0, f64::max);
        let at_origin = rows.iter().all(|row| row.w.abs() <= 1e-9 * scale);
        if scale <= 0.0 || !at_origin {
            return None;
        }
        let [n0, n1, n3] = rows.map(|row| row.truncate());
        let (k, u, v) = (n0.cross(n1), n1.cross(n3), n3.cross(n0));
        Some(Self {
            n3,
            n3_length: n3.length(),
            k,
            u,
            v,
            dots: [k.dot(k), u.dot(u), v.dot(v), k.dot(u), k.dot(v), u.dot(v)],
        })
    }
}

/// The projection of a sphere wholly in front of the eye, in NDC: the points (a, b) whose ray
/// D(a, b) ([`Camera`]) passes within r of the centre C, (C·D)² ≥ (|C|² − r²)|D|²: the
/// ellipse Q(a, b) = A a² + 2P ab + S b² + 2R a + 2T b + W ≥ 0, A < 0. At a fixed b its chord
/// is the roots of a quadratic in a; its x and y ranges and the y of its leftmost and
/// rightmost points follow from Q's partial derivatives.
struct Ellipse {
    /// A, P, S, R, T, W.
    q: [f64; 6],
    /// 1/A.
    inverse_a: f64,
    /// The NDC x and y ranges.
    x: (f64, f64),
    y: (f64, f64),
    /// The NDC y of its leftmost and rightmost points.
    y_of_x: (f64, f64),
}

impl Ellipse {
    fn new(camera: &Camera, centre: Vec3, r: f32) -> Option<Self> {
        let c = centre.as_dvec3();
        let r = f64::from(r);
        // The sphere on the front side of the plane w = 0, not reaching it (NaN: no), with a
        // relative margin: one that all but touches the plane makes a conic too
        // ill-conditioned for f64, and takes the billboard.
        let clear = r * camera.n3_length * (1.0 + 1e-6);
        if camera.n3.dot(c).partial_cmp(&clear) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        let s = c.length_squared() - r * r;
        let (ck, cu, cv) = (c.dot(camera.k), c.dot(camera.u), c.dot(camera.v));
        let [kk, uu, vv, ku, kv, uv] = camera.dots;
        let (a, p, sb) = (cu * cu - s * uu, cu * cv - s * uv, cv * cv - s * vv);
        let (ra, t, w) = (ck * cu - s * ku, ck * cv - s * kv, ck * ck - s * kk);
        // Where ∂Q/∂b = 0 (the leftmost and rightmost points), b = −(P a + T)/S; on Q = 0
        // there, (A − P²/S) a² + 2(R − PT/S) a + (W − T²/S) = 0. Likewise for the y range,
        // with ∂Q/∂a = 0.
        let roots = |a2: f64, b2: f64, c2: f64| {
            let root = (b2 * b2 - a2 * c2).max(0.0).sqrt();
            let inverse = 1.0 / a2;
            let (r0, r1) = ((-b2 + root) * inverse, (-b2 - root) * inverse);
            (r0.min(r1), r0.max(r1))
        };
        let (inverse_a, inverse_s) = (1.0 / a, 1.0 / sb);
        let x = roots(
            a - p * p * inverse_s,
            ra - p * t * inverse_s,
            w - t * t * inverse_s,
        );
        let y = roots(
            sb - p * p * inverse_a,
            t - p * ra * inverse_a,
            w - ra * ra * inverse_a,
        );
        let y_at = |x: f64| -(p * x + t) * inverse_s;
        let ellipse = Self {
            q: [a, p, sb, ra, t, w],
            inverse_a,
            x,
            y,
            y_of_x: (y_at(x.0), y_at(x.1)),
        };
        let finite = [x.0, x.1, y.0, y.1, ellipse.y_of_x.0, ellipse.y_of_x.1]
            .iter()
            .all(|v| v.is_finite());
        (a < 0.0 && sb < 0.0 && finite).then_some(ellipse)
    }

    /// The chord at NDC y = b, b clamped to the ellipse's y range (at its ends, a point).
    fn clamped_chord(&self, b: f64) -> (f64, f64) {
        let [a, p, s, r, t, w] = self.q;
        let b = b.clamp(self.y.0, self.y.1);
        let half_b = p * b + r;
        let c = (s * b + 2.0 * t) * b + w;
        let root = (half_b * half_b - a * c).max(0.0).sqrt();
        // A < 0: Q ≥ 0 between the roots, (−B + root)/A ≤ (−B − root)/A.
        (
            (-half_b + root) * self.inverse_a,
            (-half_b - root) * self.inverse_a,
        )
    }

    /// The x range of the ellipse over the NDC rows `band` = (b₀, b₁), given the
    /// [`Ellipse::clamped_chord`]s at its ends, or `None` where the band misses it. Its left
    /// edge is convex in y and its right edge concave: over the band each takes its extreme at
    /// the ellipse's leftmost (rightmost) point where the band holds it, else at an end.
    fn x_range(&self, band: (f64, f64), (c0, c1): ((f64, f64), (f64, f64))) -> Option<(f64, f64)> {
        let (b0, b1) = (band.0.max(self.y.0), band.1.min(self.y.1));
        if b0 > b1 {
            return None;
        }
        let inside = |y: f64| b0 <= y && y <= b1;
        let left = match inside(self.y_of_x.0) {
            true => self.x.0,
            false => c0.0.min(c1.0),
        };
        let right = match inside(self.y_of_x.1) {
            true => self.x.1,
            false => c0.1.max(c1.1),
        };
        Some((left, right))
    }
}

/// The pixel-space rectangle `(lo, hi)` of the photon volumes' billboard of the sphere of
/// radius `r` at the eye-relative `centre` (`d` from the eye, the billboard's half size
/// `half`), clipped to the part in front of the eye; `None` where none of it is. Conservative
/// but loose (up to twice the projection's area): for spheres that reach the eye's plane.
fn billboard_rect(
    view_proj: &Mat4,
    size: (f32, f32),
    centre: Vec3,
    (d, r, half): (f32, f32, f32),
) -> Option<(glam::Vec2, glam::Vec2)> {
    // The billboard's corners (any square perpendicular to the eye ray covers it).
    let dir = centre / d;
    let (t, b) = dir.any_orthonormal_pair();
    let far = dir * (d + r);
    let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .map(|(u, v)| view_proj * (far + (t * u + b * v) * half).extend(1.0));
    // Clipped to w ≥ ε (Sutherland–Hodgman, one plane): the part behind the eye projects
    // nowhere, the part just in front of it far off screen.
    const EPS: f32 = 1e-6;
    let mut lo = glam::Vec2::splat(f32::INFINITY);
    let mut hi = glam::Vec2::splat(f32::NEG_INFINITY);
    let mut any = false;
    let mut project = |p: Vec4| {
        let ndc = glam::Vec2::new(p.x, p.y) / p.w;
        let px = (ndc * 0.5 + 0.5) * glam::Vec2::new(size.0, size.1);
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
    any.then_some((lo, hi))
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
    /// sphere, eye-relative centre and radius, a little wider than the shader's (radius 0 for a
    /// photon left out), which the shader culls against before it unpacks the photon; in
    /// half floats ([`PackedSphere`]).
    pub spheres: Vec<PackedSphere>,
}

/// A bounding sphere in half floats, as `photon_tiles.comp` reads it
/// (`vec4(unpackHalf2x16(s.x), unpackHalf2x16(s.y))`): centre x | y, then centre z | radius,
/// the first of each pair in the low 16 bits. Half the bytes of four `f32`s: the gather reads
/// one sphere per list entry and subgroup, each lane's load a scalar one on llvmpipe, and these
/// reads were 11–19 % of its time (docs/performance.md, "Spheres in half floats").
pub type PackedSphere = [u32; 2];

/// `f16` bits of `x ≥ 0`, rounded up (+∞ above the largest half).
fn half_up(x: f64) -> u16 {
    let h = half::f16::from_f64(x);
    match h.to_f64() < x && h.is_finite() {
        true => h.to_bits() + 1, // the next half up (+∞ after the largest)
        false => h.to_bits(),
    }
}

/// The sphere of radius `r` around `centre` in half floats, holding the whole sphere given:
/// the centre rounded to the nearest halves, the radius widened by that rounding and rounded
/// up. No half is subnormal (a device may flush those to zero when it converts them, unless
/// the shader asks to keep them): a centre coordinate below the smallest normal half is 0, the
/// radius at least that half (61 µm). A centre beyond the halves' range (65 504 m from the eye)
/// gets an infinite radius around the eye, which every box reaches: the shader's exact test
/// decides. A non-positive radius is 0 (reaches nothing).
fn pack_sphere(centre: Vec3, r: f32) -> PackedSphere {
    if r.is_nan() || r <= 0.0 || !centre.is_finite() {
        return [0, 0];
    }
    let c = centre.to_array().map(|x| match half::f16::from_f32(x) {
        h if is_subnormal(h.to_bits()) => half::f16::ZERO,
        h => h,
    });
    let (c, r) = match c.iter().all(|h| h.is_finite()) {
        true => {
            let moved = Vec3::from_array(c.map(half::f16::to_f32))
                .as_dvec3()
                .distance(centre.as_dvec3());
            let r = f64::from(r) + moved * (1.0 + 1e-6);
            (
                c,
                half_up(r.max(f64::from(f32::from(half::f16::MIN_POSITIVE)))),
            )
        }
        false => ([half::f16::ZERO; 3], half::f16::INFINITY.to_bits()),
    };
    let pair = |lo: u16, hi: u16| u32::from(lo) | (u32::from(hi) << 16);
    [
        pair(c[0].to_bits(), c[1].to_bits()),
        pair(c[2].to_bits(), r),
    ]
}

/// Whether the half with these bits is subnormal (exponent 0, mantissa not).
fn is_subnormal(bits: u16) -> bool {
    bits & 0x7c00 == 0 && bits & 0x03ff != 0
}

impl TileLists {
    pub fn tiles(&self) -> usize {
        (self.columns * self.rows) as usize
    }

    /// Where photon buffer `buffer`'s offsets begin.
    pub fn first(&self, buffer: usize) -> u32 {
        (buffer * (self.tiles() + 1)) as u32
    }

    /// The length of each of buffer `buffer`'s tile lists, tile by tile (none for a buffer
    /// without lists).
    pub fn lengths(&self, buffer: usize) -> Vec<u32> {
        let first = self.first(buffer) as usize;
        self.offsets
            .get(first..=first + self.tiles())
            .map_or_else(Vec::new, |o| o.windows(2).map(|w| w[1] - w[0]).collect())
    }

    /// The length of buffer `buffer`'s longest tile list (0 for a buffer without lists).
    pub fn longest(&self, buffer: usize) -> usize {
        self.lengths(buffer).into_iter().max().unwrap_or(0) as usize
    }

    /// The photons of tile `tile` from buffer `buffer`.
    pub fn list(&self, buffer: usize, tile: usize) -> &[u32] {
        let first = self.first(buffer) as usize + tile;
        &self.indices[self.offsets[first] as usize..self.offsets[first + 1] as usize]
    }
}

/// A kept photon's buffer, index in it, inclusive tile rows `y0..=y1` and where its rows'
/// column spans ([`Screen::tile_spans`]) begin in its part's span list.
type Rect = (u32, u32, [u32; 3]);

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
    let camera = Camera::new(&screen.view_proj);
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

    // 1. Each photon's bounding sphere, and its tile rows (with their column spans) in the
    // bucket of every band they reach: runs of the map, each in map order.
    let run = total
        .div_ceil(if threads > 1 { threads * 4 } else { 1 })
        .max(1);
    let runs: Vec<usize> = (0..total).step_by(run).collect();
    type Part = (Vec<PackedSphere>, Vec<Vec<Rect>>, Vec<[u32; 2]>);
    let parts: Vec<Part> = map_in_order(runs, threads, |start| {
        let range = start..(start + run).min(total);
        let mut spheres = Vec::with_capacity(range.len());
        let mut buckets: Vec<Vec<Rect>> = vec![Vec::new(); bands.len()];
        let mut spans = Vec::new();
        for (k, photon) in range.clone().zip(photons(range)) {
            let b = firsts.partition_point(|&f| f <= k) - 1;
            let i = (k - firsts[b]) as u32;
            let centre = photon.position + offset;
            if !photon.power.cmpgt(Vec3::ZERO).any() || !centre.is_finite() {
                spheres.push([0, 0]);
                continue;
            }
            let (_, r_knn) = unpack_normal(photon.normal);
            let (r, _) = kernel_radius(r_knn, kernel, centre.length());
            let r = r * RADIUS_MARGIN;
            spheres.push(pack_sphere(centre, r));
            let at = spans.len() as u32;
            if let Some((y0, y1)) = screen.tile_spans(camera.as_ref(), centre, r, &mut spans) {
                for bucket in &mut buckets[(y0 / band_rows) as usize..=(y1 / band_rows) as usize] {
                    bucket.push((b as u32, i, [y0, y1, at]));
                }
            }
        }
        (spheres, buckets, spans)
    });
    // Band `band`'s photons' tile rows, in map order, each with its rows' column spans.
    let rects = |band: usize| {
        parts.iter().flat_map(move |(_, buckets, spans)| {
            buckets[band]
                .iter()
                .map(move |rect @ (_, _, [y0, y1, at])| {
                    (rect, &spans[*at as usize..][..(y1 - y0 + 1) as usize])
                })
        })
    };

    // 2. Each band counts its tiles' entries. The tiles of a photon's rows `y0..=y1` (with
    // their column `spans`) in rows `r0..r1`, as indices relative to the band's first tile:
    fn band_tiles<'a>(
        [y0, y1, _]: [u32; 3],
        spans: &'a [[u32; 2]],
        (r0, r1): (u32, u32),
        columns: u32,
    ) -> impl Iterator<Item = usize> + 'a {
        (y0.max(r0)..=y1.min(r1 - 1)).flat_map(move |y| {
            let [x0, x1] = spans[(y - y0) as usize];
            (x0..=x1).map(move |x| ((y - r0) * columns + x) as usize)
        })
    }
    let jobs: Vec<(usize, (u32, u32))> = bands.iter().copied().enumerate().collect();
    let band_counts = map_in_order(jobs, threads, |(index, band)| {
        let size = ((band.1 - band.0) * columns) as usize;
        let mut count = vec![0u32; buffers * size];
        for ((b, _, rect), spans) in rects(index) {
            for t in band_tiles(*rect, spans, band, columns) {
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
    // Every photon's tiles, band by band.
    debug_assert_eq!(
        sum as usize,
        (bands.iter().enumerate())
            .flat_map(|(index, &band)| rects(index).map(move |rect| (band, rect)))
            .map(|(band, ((_, _, rect), spans))| band_tiles(*rect, spans, band, columns).count())
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
        for ((b, i, rect), spans) in rects(index) {
            let b = *b as usize;
            for t in band_tiles(*rect, spans, band, columns) {
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
        spheres: parts
            .into_iter()
            .flat_map(|(spheres, _, _)| spheres)
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::types::pack_normal;

    /// The sphere [`pack_sphere`] packed, unpacked as the shader reads it.
    fn unpack_sphere(s: PackedSphere) -> Vec4 {
        let half = |bits: u32| half::f16::from_bits(bits as u16).to_f32();
        Vec4::new(half(s[0]), half(s[0] >> 16), half(s[1]), half(s[1] >> 16))
    }

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
                    let mut u =
                        Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
                    if u.length() > 1.0 || u.length() < 1e-3 {
                        continue;
                    }
                    // Half of them on the surface: the projection's edge (the lists are cut
                    // to it, `Screen::tile_spans`).
                    if rng.next_f32() < 0.5 {
                        u = u.normalize();
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
    fn the_tile_spans_hold_every_tile_a_pixel_ray_through_the_sphere_shades_and_little_more() {
        let mut rng = crate::photon::rng::Rng::new(5);
        // Also a size that is no multiple of the tiles or of N (the last row of targets
        // shades the clamped G-buffer row).
        let cases = [1, 2, 3].map(|n| (n, (160, 120))).into_iter();
        for (subsample, size) in cases.chain([(1, (157, 113)), (3, (157, 113))]) {
            let screen = Screen {
                size,
                ..screen(subsample)
            };
            let inverse = screen.view_proj.inverse();
            let forward = Vec3::new(0.1, -0.2, -1.0).normalize(); // screen()'s view
            let (tw, th) = screen.target();
            let (w, h) = screen.size;
            let (columns, rows) = screen.tiles();
            let n = subsample;
            let (mut listed, mut reached) = (0, 0);
            for k in 0..300 {
                let dir = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, -1.0).normalize();
                let d = 0.5 + 10.0 * rng.next_f32();
                let mut centre = dir * d;
                let mut r = [0.01, 0.05, 0.2, 0.6][k % 4] * d;
                // One in five all but touching the eye's plane from in front, touching it, or
                // across it: the ellipse's ill-conditioned edge and the billboard's fallback,
                // whose rectangles are not tight (coverage only).
                let grazing = k % 5 == 4;
                if grazing {
                    let gap = [1e-7, 1e-5, 1e-3, 0.0, -0.3][(k / 5) % 5];
                    let side = centre - forward * centre.dot(forward);
                    r = 0.3 * d;
                    centre = side * 0.5 + forward * r * (1.0 + gap);
                }
                let mut spans = Vec::new();
                let camera = Camera::new(&screen.view_proj);
                let Some((y0, y1)) = screen.tile_spans(camera.as_ref(), centre, r, &mut spans)
                else {
                    continue;
                };
                assert_eq!(spans.len(), (y1 - y0 + 1) as usize);
                let mut hit = vec![false; (columns * rows) as usize];
                // Every target pixel whose shaded G-buffer pixel's centre ray meets the sphere.
                for ty in 0..th {
                    for tx in 0..tw {
                        let g = ((tx * n + n / 2).min(w - 1), (ty * n + n / 2).min(h - 1));
                        let ndc = glam::Vec2::new(
                            (g.0 as f32 + 0.5) / w as f32 * 2.0 - 1.0,
                            (g.1 as f32 + 0.5) / h as f32 * 2.0 - 1.0,
                        );
                        let far = inverse * glam::Vec4::new(ndc.x, ndc.y, 0.5, 1.0);
                        let ray = (far.truncate() / far.w).normalize();
                        let along = ray.dot(centre);
                        if along > 0.0 && (centre - ray * along).length() < r {
                            hit[(ty / PHOTON_TILE * columns + tx / PHOTON_TILE) as usize] = true;
                        }
                    }
                }
                // (A sphere that reaches no pixel's centre may still be listed: the margin, or
                // one between pixel centres.)
                let reaches_any = hit.iter().any(|&h| h);
                for ty in 0..rows {
                    for tx in 0..columns {
                        let span = (ty >= y0 && ty <= y1).then(|| spans[(ty - y0) as usize]);
                        let inside = span.is_some_and(|[a, b]| a <= tx && tx <= b);
                        if hit[(ty * columns + tx) as usize] {
                            reached += usize::from(!grazing);
                            assert!(
                                inside,
                                "{size:?} at subsample {subsample}: sphere {centre} r {r} reaches tile \
                                 ({tx}, {ty}), not in its span {span:?}"
                            );
                        }
                        if inside && !grazing {
                            listed += 1;
                            // Tight: a listed tile has a reached tile beside it (one tile of
                            // margin, for the pixel of margin each way).
                            let any_near = (ty.saturating_sub(1)..=(ty + 1).min(rows - 1))
                                .flat_map(|y| {
                                    (tx.saturating_sub(1)..=(tx + 1).min(columns - 1))
                                        .map(move |x| (y * columns + x) as usize)
                                })
                                .any(|t| hit[t]);
                            assert!(
                                any_near || !reaches_any,
                                "{size:?} at subsample {subsample}: sphere {centre} r {r} lists tile \
                                 ({tx}, {ty}), far from every tile it reaches"
                            );
                        }
                    }
                }
            }
            assert!(
                reached > 1000,
                "{size:?} at subsample {subsample}: {reached} tiles reached"
            );
            // Corner tiles of large kernels' rectangles are left out (the rectangles list 1.2×
            // the reached tiles here, the spans 1.05–1.09×): the lists are within a
            // few tiles per sphere of the reached tiles.
            assert!(
                listed < reached + reached / 8,
                "{size:?} at subsample {subsample}: {listed} tiles listed for {reached} reached"
            );
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
    fn a_packed_sphere_holds_the_sphere_it_packs() {
        // Centres from a millimetre to 50 km from the eye (per axis), radii from a micrometre
        // to metres: every point of the sphere given lies in the half-float sphere, which is not
        // much larger (its radius grows by at most the centre's rounding, half a half's spacing
        // per axis, plus two spacings of the radius, and is at least the smallest normal half).
        let mut rng = crate::photon::rng::Rng::new(7);
        for i in 0..20_000 {
            let scale = 10f32.powf(-3.0 + 7.7 * rng.next_f32());
            let centre = (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0
                - Vec3::ONE)
                * scale;
            let r = 10f32.powf(-6.0 + 6.5 * rng.next_f32());
            let packed = unpack_sphere(pack_sphere(centre, r));
            let (c, r16) = (packed.truncate().as_dvec3(), f64::from(packed.w));
            let moved = c.distance(centre.as_dvec3());
            assert!(
                moved + f64::from(r) <= r16,
                "{i}: {centre} r {r} packed as {packed}"
            );
            let spacing = |x: f32| f64::from(x.abs()).max(6.1e-5) * 2f64.powi(-10);
            // The centre's rounding (half a spacing, or the whole coordinate below the smallest
            // normal half) and the radius's.
            let rounding = |x: f32| match x.abs() < 6.11e-5 {
                true => f64::from(x.abs()),
                false => 0.5 * spacing(x),
            };
            let grown = r16 - f64::from(r.max(6.1035e-5));
            let bound = centre.to_array().map(rounding).iter().sum::<f64>()
                + 2.0 * spacing(r + moved as f32);
            assert!(
                grown <= bound,
                "{i}: {centre} r {r} grew by {grown} > {bound}"
            );
            // No subnormal half: a device may flush them to zero.
            let bits = pack_sphere(centre, r);
            for h in [bits[0], bits[0] >> 16, bits[1], bits[1] >> 16] {
                assert!(!is_subnormal(h as u16), "{i}: {centre} r {r}");
            }
        }
        // The layout the shader unpacks: centre x | y, centre z | radius, the first in the low
        // 16 bits (1.0 = 0x3c00, 2.0 = 0x4000, -2.0 = 0xc000, 0.5 = 0x3800).
        assert_eq!(
            pack_sphere(Vec3::new(1.0, 2.0, -2.0), 0.5),
            [0x4000_3c00, 0x3800_c000]
        );
        // Tiny: the centre coordinate below the smallest normal half is 0, the radius at least
        // that half, and still holding the sphere.
        let tiny = unpack_sphere(pack_sphere(Vec3::new(1e-6, 0.25, 3.0), 1e-7));
        assert_eq!(tiny.x, 0.0);
        assert!(tiny.w >= 1e-6 + 1e-7 && tiny.w <= 1e-4, "{tiny}");
        // Beyond the halves: every box reaches it (the exact test decides).
        let far = unpack_sphere(pack_sphere(Vec3::new(70_000.0, 0.0, -1.0), 0.5));
        assert_eq!(far, Vec4::new(0.0, 0.0, 0.0, f32::INFINITY));
        // Left out: reaches nothing.
        assert_eq!(pack_sphere(Vec3::ONE, 0.0), [0, 0]);
        assert_eq!(pack_sphere(Vec3::new(f32::NAN, 0.0, 0.0), 1.0), [0, 0]);
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
