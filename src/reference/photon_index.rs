//! Hashed uniform grids over stored photons for the gather, one per class of kernel radius, so
//! that a query visits the photons whose kernels are about as large as the cells it looks in.
//! Built by counting sorts (deterministic), queried without allocation per photon.
//!
//! ```text
//!   class c holds the photons with radius in (R/2^(c+1), R/2^c]   (R: the largest radius;
//!   cell of class c = R/2^c                                         the last class: all smaller)
//!   a query at p visits, per class whose photons' box (grown by a cell) holds p, the 27 cells
//!   around p, and of their photons those whose kernel sphere holds p
//! ```
//!
//! One grid with the largest radius as its cell (what this was before) made every query look at
//! every photon within 1.5 R: where kNN radii span two orders of magnitude (a focused caustic
//! beside sparse global photons) a gather visited hundreds of photons for the tens whose kernels
//! hold it (docs/performance.md, "Gathering by radius class").

use crate::photon::types::Photon;
use glam::{IVec3, Vec3, Vec4};

/// Most radius classes; photons smaller than R/2^(CLASSES − 1) share the last.
const CLASSES: usize = 8;

pub struct PhotonGrid {
    classes: Vec<Class>,
}

/// The grid of one radius class.
struct Class {
    cell: f32,
    /// The class's photons' bounds, grown by one cell: a query outside skips the class.
    lo: Vec3,
    hi: Vec3,
    mask: u32,
    /// `starts[b]..starts[b + 1]` indexes `points` and `order` for bucket b.
    starts: Vec<u32>,
    /// Position and squared radius of each photon, in bucket order (the sphere test reads only
    /// these, contiguously).
    points: Vec<Vec4>,
    /// The photon index of each entry of `points`.
    order: Vec<u32>,
}

fn bucket(c: IVec3, mask: u32) -> u32 {
    let h = (c.x as u32).wrapping_mul(73_856_093)
        ^ (c.y as u32).wrapping_mul(19_349_663)
        ^ (c.z as u32).wrapping_mul(83_492_791);
    h & mask
}

/// The cell of class `class` (module docs).
fn cell_size(largest: f32, class: usize) -> f32 {
    largest / (1u32 << class) as f32
}

fn cell_of(p: Vec3, cell: f32) -> IVec3 {
    (p / cell).floor().as_ivec3()
}

impl PhotonGrid {
    /// The grids of `photons` with kernel radii `radii` (a photon is visited where the sphere
    /// of its radius holds the query point; radius 0 or not finite: never).
    pub fn new(photons: &[Photon], radii: &[f32]) -> Self {
        debug_assert_eq!(photons.len(), radii.len());
        let usable = |r: f32| r > 0.0 && r.is_finite();
        let largest = radii
            .iter()
            .copied()
            .filter(|&r| usable(r))
            .fold(0.0f32, f32::max);
        let mut members: Vec<Vec<u32>> = vec![Vec::new(); CLASSES];
        for (i, &r) in radii.iter().enumerate() {
            if usable(r) {
                // r ≤ largest, so the ratio is ≥ 1 and the class ≥ 0; the cell must hold r
                // whatever log2 rounded.
                let mut class = ((largest / r).log2().floor() as usize).min(CLASSES - 1);
                while class > 0 && r > cell_size(largest, class) {
                    class -= 1;
                }
                members[class].push(i as u32);
            }
        }
        let classes = members
            .iter()
            .enumerate()
            .filter(|(_, m)| !m.is_empty())
            .map(|(c, m)| Class::new(photons, radii, m, cell_size(largest, c)))
            .collect();
        Self { classes }
    }

    /// Calls `visit(index)` once for every photon whose kernel sphere holds `p`
    /// (`|p − position| < radius`), class after class.
    pub fn for_each_near(&self, p: Vec3, mut visit: impl FnMut(usize)) {
        for class in &self.classes {
            class.for_each_near(p, &mut visit);
        }
    }
}

impl Class {
    fn new(photons: &[Photon], radii: &[f32], members: &[u32], cell: f32) -> Self {
        let size = members.len().next_power_of_two() as u32;
        let mask = size - 1;
        let keys: Vec<u32> = members
            .iter()
            .map(|&i| bucket(cell_of(photons[i as usize].position, cell), mask))
            .collect();
        let mut starts = vec![0u32; size as usize + 1];
        for &k in &keys {
            starts[k as usize + 1] += 1;
        }
        for i in 0..size as usize {
            starts[i + 1] += starts[i];
        }
        let mut fill = starts.clone();
        let mut order = vec![0u32; members.len()];
        for (&i, &k) in members.iter().zip(&keys) {
            order[fill[k as usize] as usize] = i;
            fill[k as usize] += 1;
        }
        let points = order
            .iter()
            .map(|&i| {
                let r = radii[i as usize];
                photons[i as usize].position.extend(r * r)
            })
            .collect();
        let (lo, hi) = members.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), &i| {
                let p = photons[i as usize].position;
                (lo.min(p), hi.max(p))
            },
        );
        Self {
            cell,
            lo: lo - cell,
            hi: hi + cell,
            mask,
            starts,
            points,
            order,
        }
    }

    fn for_each_near(&self, p: Vec3, visit: &mut impl FnMut(usize)) {
        if p.cmplt(self.lo).any() || p.cmpgt(self.hi).any() {
            return;
        }
        let c = cell_of(p, self.cell);
        let mut buckets = [0u32; 27];
        let mut n = 0;
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    buckets[n] = bucket(c + IVec3::new(dx, dy, dz), self.mask);
                    n += 1;
                }
            }
        }
        // Neighbouring cells may share a bucket: each bucket once.
        buckets.sort_unstable();
        let mut last = None;
        for b in buckets {
            if last == Some(b) {
                continue;
            }
            last = Some(b);
            let range = self.starts[b as usize] as usize..self.starts[b as usize + 1] as usize;
            for (q, &i) in self.points[range.clone()].iter().zip(&self.order[range]) {
                if (q.truncate() - p).length_squared() < q.w {
                    visit(i as usize);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::rng::Rng;

    /// Radii over three orders of magnitude (every class, the last one's smaller ones too), a
    /// zero and a NaN: each photon whose sphere holds the query is visited once, no other.
    #[test]
    fn grid_visits_exactly_the_photons_whose_sphere_holds_the_point_once() {
        let mut rng = Rng::new(5);
        let mut unit = move || rng.next_f32();
        let point = |u: &mut dyn FnMut() -> f32| Vec3::new(u(), u(), u()) * 4.0 - 2.0;
        let photons: Vec<Photon> = (0..3000)
            .map(|_| Photon {
                position: point(&mut unit),
                ..Photon::default()
            })
            .collect();
        let mut radii: Vec<f32> = (0..photons.len())
            .map(|_| 0.6 * 1000f32.powf(-unit()))
            .collect();
        radii[0] = 0.0;
        radii[1] = f32::NAN;
        let grid = PhotonGrid::new(&photons, &radii);
        assert!(grid.classes.len() == CLASSES, "every class used");
        // Photons whose sphere held a query: all, and those of radius under 6 mm (the classes
        // past the fifth).
        let (mut covered, mut small) = (0, 0);
        for q in 0..400 {
            // Half the queries inside some photon's kernel, whatever its size.
            let p = if q % 2 == 0 {
                let r = radii[q].max(0.001);
                photons[q].position + point(&mut unit) * (0.1 * r)
            } else {
                point(&mut unit)
            };
            let mut seen = vec![0u32; photons.len()];
            grid.for_each_near(p, |i| seen[i] += 1);
            for (i, ph) in photons.iter().enumerate() {
                let holds = (ph.position - p).length_squared() < radii[i] * radii[i];
                assert_eq!(
                    seen[i],
                    u32::from(holds),
                    "photon {i} (radius {})",
                    radii[i]
                );
                covered += usize::from(holds);
                small += usize::from(holds && radii[i] < 0.006);
            }
        }
        assert!(
            covered > 500 && small > 50,
            "covered {covered}, small {small}"
        );
    }
}
