//! The order in which the gather's workgroups take the screen's tiles.
//!
//! Workgroup `i` of a gather dispatch shades tile `order[i]` (`photon_tiles.comp` reads it
//! from the offsets buffer). The order does not change a pixel's sum (each tile's pixels add
//! their own list in list order), only which tiles run side by side, and where the device
//! splits the dispatch among its cores that decides how long the pass takes:
//!
//! ```text
//!  lavapipe (Mesa's lp_cs_tpool) gives each of its P threads one block of ⌊W/P⌋ consecutive
//!  workgroups of a W-workgroup dispatch, not the next free workgroup:
//!
//!  row-major tiles, a caustic's focus under a glass sphere        balanced order
//!  ┌────────────────────────┐                               ┌────────────────────────┐
//!  │ thread 0: back wall    │  cheap lists                  │ thread 0: ½ of the cost│
//!  ├────────────────────────┤                               ├────────────────────────┤
//!  │ thread 1: floor, focus │  long lists: thread 0 idles   │ thread 1: ½ of the cost│
//!  └────────────────────────┘                               └────────────────────────┘
//! ```
//!
//! [`TileOrder::Balanced`] orders the tiles so that the first k workgroups hold about k/W of
//! the dispatch's estimated cost, for every k: then every block of consecutive workgroups, for
//! any P, holds its share, give or take the costliest tile. A GPU starts each workgroup on
//! whichever unit is free, where no order is needed; there the tiles stay in row-major order
//! ([`TileOrder::Rows`]), as neighbours share the photons their lists read.

pub use crate::config::settings::TileOrder;
use crate::layout::shared_constants::TILE_JOB;

/// A tile's estimated cost in list entries beyond those it gathers: its workgroup's launch and
/// its pixels' set-up (G-buffer reads, the BSDF). A tuned value: on lavapipe at 640×480 an
/// empty tile's workgroup costs ~4 µs (20 ms for 4800), the set-up of a tile with a list ~8
/// µs, an entry 0.6–1 µs (docs/performance.md, "Lists cut to the ellipse"): ~4–7 entries for
/// an empty tile, ~12–20 for one with a list.
const TILE_COST: u64 = 12;

/// The tiles of a dispatch that gathers entries `start..start + TILE_JOB` of each tile's list,
/// in the order its workgroups take them: of the tiles whose lists have `lengths` entries
/// (tile t's list is `lengths[t]` long), every one when `all`, else those with entries past
/// `start`, in `order` (resolved: `Auto` counts as `Rows`). A tile costs `TILE_COST` plus
/// the entries this dispatch gathers of its list.
pub fn dispatch_order(lengths: &[u32], start: u32, all: bool, order: TileOrder) -> Vec<u32> {
    let tiles = (0..lengths.len() as u32).filter(|&t| all || lengths[t as usize] > start);
    match order {
        TileOrder::Balanced => balanced(tiles.collect(), |t| {
            TILE_COST + u64::from(lengths[t as usize].saturating_sub(start).min(TILE_JOB))
        }),
        TileOrder::Rows | TileOrder::Auto => tiles.collect(),
    }
}

/// `tiles` ordered so that each prefix's cost is as near its share of the total as the tiles
/// allow, keeping neighbours together where it can: the tiles costlier than the mean
/// ("heavy", a caustic's focus) and the others ("light") each stay in row-major order, and
/// the next tile is the next heavy one while the k tiles placed hold less than k/n of the
/// total, else the next light one. A heavy tile, placed while the prefix is behind, leaves it
/// ahead by less than its own cost; a light one, placed while it is not behind, leaves it
/// behind by at most the mean; once one kind runs out the other only brings the prefix back
/// towards its share. So each prefix, and each block of consecutive tiles, is within one
/// tile's cost of its share (`a_balanced_order_gives_every_block_its_share`).
fn balanced(tiles: Vec<u32>, cost: impl Fn(u32) -> u64) -> Vec<u32> {
    let n = tiles.len() as u128;
    let total: u128 = tiles.iter().map(|&t| u128::from(cost(t))).sum();
    // Heavy: cost · n > total (above the mean, in integers).
    let capacity = tiles.len();
    let (heavy, light): (Vec<u32>, Vec<u32>) = tiles
        .into_iter()
        .partition(|&t| u128::from(cost(t)) * n > total);
    let (mut heavy, mut light) = (heavy.into_iter().peekable(), light.into_iter().peekable());
    let mut out = Vec::with_capacity(capacity);
    let mut done = 0u128;
    for k in 0..n {
        // The k tiles placed hold `done`; their share is k/n of the total.
        let behind = done * n < total * k;
        let next = match (behind, heavy.peek(), light.peek()) {
            (true, Some(_), _) | (false, Some(_), None) => heavy.next(),
            _ => light.next(),
        };
        let Some(t) = next else { break }; // never: n tiles for n places
        done += u128::from(cost(t));
        out.push(t);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Tile costs like a frame's: most lists short, a few (a caustic's focus) thousands of
    /// entries long and bunched together, some tiles empty.
    fn frame_like(tiles: usize, seed: u64) -> Vec<u32> {
        let mut s = seed;
        let mut next = move || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 33) as u32
        };
        let focus = tiles / 2 + (next() as usize % (tiles / 3).max(1));
        (0..tiles)
            .map(|t| match t {
                t if t.abs_diff(focus) < tiles / 40 + 1 => 2000 + next() % 6000,
                _ if next() % 5 == 0 => 0,
                _ => next() % 120,
            })
            .collect()
    }

    #[test]
    fn every_order_takes_each_tile_with_entries_left_once() {
        for (tiles, seed) in [(0, 1), (1, 2), (7, 3), (4800, 4), (1237, 5)] {
            let lengths = frame_like(tiles, seed);
            for order in [TileOrder::Rows, TileOrder::Balanced, TileOrder::Auto] {
                for (start, all) in [(0, true), (0, false), (100, false), (5000, false)] {
                    let mut got = dispatch_order(&lengths, start, all, order);
                    got.sort_unstable();
                    let want: Vec<u32> = (0..tiles as u32)
                        .filter(|&t| all || lengths[t as usize] > start)
                        .collect();
                    assert_eq!(
                        got, want,
                        "{tiles} tiles, {order:?}, from {start}, all {all}"
                    );
                }
            }
        }
    }

    #[test]
    fn rows_keep_row_major_order() {
        let lengths = frame_like(500, 9);
        let rows = dispatch_order(&lengths, 0, false, TileOrder::Rows);
        assert!(rows.windows(2).all(|w| w[0] < w[1]));
    }

    /// A frame as small as the image tests' (96×72: 108 tiles) is reordered: the GPU test that
    /// compares the two orders' frames compares two different orders.
    #[test]
    fn a_small_frame_with_a_focus_is_reordered() {
        for seed in 20..30 {
            let lengths = frame_like(108, seed);
            assert_ne!(
                dispatch_order(&lengths, 0, true, TileOrder::Balanced),
                dispatch_order(&lengths, 0, true, TileOrder::Rows),
                "seed {seed}"
            );
        }
    }

    /// The cost of a tile in a dispatch is what that dispatch gathers of its list: a focus
    /// of many dispatches' entries counts as one dispatch's in each.
    #[test]
    fn a_dispatch_counts_only_the_entries_it_gathers() {
        // Tile 0: five dispatches' entries; tile 1: 3000; tiles 2–11: 100 each.
        let mut lengths = vec![5 * TILE_JOB, 3000];
        lengths.extend([100; 10]);
        // Counted whole, tile 0 would be the only tile above the mean and tile 1 would go
        // first with the cheap ones. Counted as one dispatch's entries, tile 1 is costlier
        // than the mean too: tile 0 goes as soon as the prefix falls behind its share, and
        // tile 1 once the cheap tiles have let the prefix fall behind again.
        let mut want = vec![2, 0];
        want.extend(3..12);
        want.push(1);
        assert_eq!(dispatch_order(&lengths, 0, true, TileOrder::Balanced), want);
        // Later dispatches: only tile 0 has entries left.
        for j in 1..5 {
            assert_eq!(
                dispatch_order(&lengths, j * TILE_JOB, false, TileOrder::Balanced),
                vec![0]
            );
        }
        assert!(dispatch_order(&lengths, 5 * TILE_JOB, false, TileOrder::Balanced).is_empty());
    }

    /// What lavapipe does with the order: P threads, each one block of consecutive
    /// workgroups. Balanced, each block's cost is within one tile's cost of its share of the
    /// total, for every P up to 64; row-major, the blocks of these frames are far apart.
    #[test]
    fn a_balanced_order_gives_every_block_its_share() {
        for (tiles, seed) in [(4800, 11), (1200, 12), (300, 13), (19_200, 14)] {
            let lengths = frame_like(tiles, seed);
            let cost = |t: u32| TILE_COST + u64::from(lengths[t as usize]);
            let worst_block = |order: &[u32], p: usize| -> (u64, u64) {
                let per = order.len() / p;
                let blocks = order.chunks(per.max(1)).take(p);
                let most = blocks.map(|b| b.iter().map(|&t| cost(t)).sum()).max();
                let total: u64 = order.iter().map(|&t| cost(t)).sum();
                (most.unwrap_or(0), total)
            };
            let max_tile = (0..tiles as u32).map(cost).max().unwrap();
            let balanced = dispatch_order(&lengths, 0, true, TileOrder::Balanced);
            for p in 1..=64 {
                if tiles / p == 0 {
                    continue;
                }
                let (most, total) = worst_block(&balanced, p);
                // A block of ⌊W/P⌋ workgroups should hold ⌊W/P⌋/W of the total.
                let share = total as f64 * (tiles / p) as f64 / tiles as f64;
                assert!(
                    (most as f64) < share + max_tile as f64,
                    "{tiles} tiles, P = {p}: a block holds {most} of {total} (share {share:.0}, \
                     costliest tile {max_tile})"
                );
            }
            let rows = dispatch_order(&lengths, 0, true, TileOrder::Rows);
            let (most, total) = worst_block(&rows, 2);
            assert!(
                most as f64 > 0.6 * total as f64,
                "the test's frames should be unbalanced in row-major order: {most} of {total}"
            );
        }
    }

    #[test]
    fn auto_balances_on_a_cpu_device_only() {
        assert_eq!(TileOrder::Auto.resolve(true), TileOrder::Balanced);
        assert_eq!(TileOrder::Auto.resolve(false), TileOrder::Rows);
        assert_eq!(TileOrder::Rows.resolve(true), TileOrder::Rows);
        assert_eq!(TileOrder::Balanced.resolve(false), TileOrder::Balanced);
    }
}
