//! Which texels of a caustic window see a caster, predicted on the CPU: the plan counts the
//! photons a light's views send before the light G-buffer is drawn (module docs, "Budget"), and
//! in a window that count depends on which texels the casters cover.
//!
//! Each caster triangle is projected into the window's grid and its texel centres tested with
//! edge functions, as the rasteriser of the light G-buffer tests them (to within its tie rule on
//! shared edges). A caster hidden behind another surface still counts as seen, and a triangle
//! reaching behind a perspective light is left out: both are rare, and only move the count.

use super::Caster;
use glam::{DMat4, DVec2, DVec3, DVec4};

/// The texels of the `width`×`height` grid over the NDC rectangle `lo`..`hi` of the view `m`
/// (origin-relative world → clip) whose centres a caster covers, row after row.
pub(super) fn covered_texels(
    m: &DMat4,
    origin: DVec3,
    casters: &[Caster],
    (lo, hi): (DVec2, DVec2),
    (width, height): (u32, u32),
) -> Vec<bool> {
    const EPS: f64 = 1e-9;
    let mut covered = vec![false; (width as usize) * (height as usize)];
    let size = DVec2::new(f64::from(width), f64::from(height));
    let to_grid = |c: DVec4| (DVec2::new(c.x, c.y) / c.w - lo) / (hi - lo) * size;
    for caster in casters {
        let clip = caster.clip(m, origin);
        for t in &caster.triangles {
            let [a, b, c] = t.map(|i| clip[i as usize]);
            if a.w <= EPS || b.w <= EPS || c.w <= EPS {
                continue;
            }
            let [a, b, c] = [a, b, c].map(to_grid);
            let area = (b - a).perp_dot(c - a);
            if area == 0.0 || !area.is_finite() {
                continue;
            }
            let (min, max) = (a.min(b).min(c), a.max(b).max(c));
            // Texel centres x + ½ inside the box, clamped to the grid.
            let first = |v: f64| (v - 0.5).ceil().max(0.0);
            let last = |v: f64, n: f64| (v - 0.5).floor().min(n - 1.0);
            let (x0, x1) = (first(min.x), last(max.x, size.x));
            let (y0, y1) = (first(min.y), last(max.y, size.y));
            if x0 > x1 || y0 > y1 {
                continue;
            }
            let sign = area.signum();
            for y in y0 as u32..=y1 as u32 {
                for x in x0 as u32..=x1 as u32 {
                    let p = DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5);
                    let inside = [(a, b), (b, c), (c, a)]
                        .iter()
                        .all(|&(e0, e1)| sign * (e1 - e0).perp_dot(p - e0) >= 0.0);
                    if inside {
                        covered[(y * width + x) as usize] = true;
                    }
                }
            }
        }
    }
    covered
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Aabb;

    #[test]
    fn a_square_caster_covers_the_texels_whose_centres_it_holds() {
        // A square from NDC −0.5 to 0.5 at depth 1 in front of an orthographic identity view:
        // the middle half of an 8 × 8 grid over the whole view, 4 × 4 texels.
        let vertices = vec![
            DVec3::new(-0.5, -0.5, 0.5),
            DVec3::new(0.5, -0.5, 0.5),
            DVec3::new(0.5, 0.5, 0.5),
            DVec3::new(-0.5, 0.5, 0.5),
        ];
        let caster = Caster {
            vertices,
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            bounds: Aabb::EMPTY,
        };
        let grid = (DVec2::NEG_ONE, DVec2::ONE);
        let covered = covered_texels(&DMat4::IDENTITY, DVec3::ZERO, &[caster], grid, (8, 8));
        let count = covered.iter().filter(|&&c| c).count();
        assert_eq!(count, 16);
        assert!(covered[3 * 8 + 3] && covered[4 * 8 + 4] && !covered[9]);
    }
}
