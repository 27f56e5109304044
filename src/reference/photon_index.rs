//! A hashed uniform grid over stored photons for the gather: cell size = the largest kernel
//! radius, so the photons whose kernels can cover a point lie in the 27 cells around it.
//! Built by a counting sort (deterministic), queried without allocation per photon.

use crate::photon::types::Photon;
use glam::{IVec3, Vec3};

pub struct PhotonGrid {
    cell: f32,
    mask: u32,
    /// `starts[b]..starts[b + 1]` indexes `order` for bucket b.
    starts: Vec<u32>,
    order: Vec<u32>,
}

fn bucket(c: IVec3, mask: u32) -> u32 {
    let h = (c.x as u32).wrapping_mul(73_856_093)
        ^ (c.y as u32).wrapping_mul(19_349_663)
        ^ (c.z as u32).wrapping_mul(83_492_791);
    h & mask
}

impl PhotonGrid {
    /// `cell` must be ≥ every kernel radius that will be queried.
    pub fn new(photons: &[Photon], cell: f32) -> Self {
        let cell = if cell > 0.0 && cell.is_finite() {
            cell
        } else {
            1.0
        };
        let size = photons.len().max(1).next_power_of_two() as u32;
        let mask = size - 1;
        let keys: Vec<u32> = photons
            .iter()
            .map(|p| bucket(Self::cell_of(p.position, cell), mask))
            .collect();
        let mut starts = vec![0u32; size as usize + 1];
        for &k in &keys {
            starts[k as usize + 1] += 1;
        }
        for i in 0..size as usize {
            starts[i + 1] += starts[i];
        }
        let mut fill = starts.clone();
        let mut order = vec![0u32; photons.len()];
        for (i, &k) in keys.iter().enumerate() {
            order[fill[k as usize] as usize] = i as u32;
            fill[k as usize] += 1;
        }
        Self {
            cell,
            mask,
            starts,
            order,
        }
    }

    fn cell_of(p: Vec3, cell: f32) -> IVec3 {
        (p / cell).floor().as_ivec3()
    }

    /// Calls `visit(index)` once for every photon in the 27 cells around `p` (and possibly
    /// others that share their buckets: the caller's kernel test rejects those).
    pub fn for_each_near(&self, p: Vec3, mut visit: impl FnMut(usize)) {
        let c = Self::cell_of(p, self.cell);
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
        buckets.sort_unstable();
        let mut last = None;
        for b in buckets {
            if last == Some(b) {
                continue;
            }
            last = Some(b);
            let (s, e) = (self.starts[b as usize], self.starts[b as usize + 1]);
            for &i in &self.order[s as usize..e as usize] {
                visit(i as usize);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::rng::Rng;

    #[test]
    fn grid_visits_every_photon_within_the_cell_size_exactly_once() {
        let mut rng = Rng::new(5);
        let mut point = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0 - 2.0;
        let photons: Vec<Photon> = (0..3000)
            .map(|_| Photon {
                position: point(),
                ..Photon::default()
            })
            .collect();
        let r = 0.3;
        let grid = PhotonGrid::new(&photons, r);
        for _ in 0..200 {
            let q = point();
            let mut seen = vec![0u32; photons.len()];
            grid.for_each_near(q, |i| seen[i] += 1);
            for (i, p) in photons.iter().enumerate() {
                assert!(seen[i] <= 1, "photon {i} visited twice");
                if (p.position - q).length() < r {
                    assert_eq!(seen[i], 1, "photon {i} within r missed");
                }
            }
        }
    }
}
