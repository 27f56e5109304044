//! Deterministic random numbers shared bit for bit with the GPU (`glsl/common/rng.glsl`).
//!
//! Two pieces, both 32-bit so a shader needs no 64-bit integers:
//! - [`pcg_hash`]: the PCG RXS-M-XS 32/32 output permutation applied to one LCG step
//!   (Jarzynski & Olano, "Hash Functions for GPU Rendering", JCGT 2020). It seeds streams.
//! - [`Rng`]: a PCG RXS-M-XS 32/32 generator (period 2³²), one `u32` of state, which is plenty
//!   for one photon path or one pixel sample.
//!
//! Seeding is frame-coherent (DESIGN.md §2.3). The CPU references seed an emitted photon from
//! the light's position bits and its index ([`seed_bounce_map_texel`]) and a path from the bits
//! of where it starts ([`seed_from_position`]). The renderer's bounce map seeds a texel from its
//! light's *index* and the texel index, and the CPU path that continues it from the same pair
//! (`bounce_plan::BouncePlan::photon_starts`): a moving light keeps its random numbers, so its photons
//! move with it rather than flicker (docs/stability.md). Static light and geometry give the same
//! photons every frame either way. `-0.0` is canonicalised to `+0.0` before hashing, on both
//! sides.
//!
//! [`PCG_HASH_TEST_VECTORS`] and [`RNG_TEST_VECTORS`] pin the outputs; the GPU-side test compares
//! `rng.glsl` against the same tables.

use glam::Vec3;

const LCG_MULTIPLIER: u32 = 747_796_405;
const LCG_INCREMENT: u32 = 2_891_336_453;
const RXS_M_XS_MULTIPLIER: u32 = 277_803_737;

/// The RXS-M-XS output permutation of PCG on a 32-bit state.
#[inline]
fn rxs_m_xs(state: u32) -> u32 {
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(RXS_M_XS_MULTIPLIER);
    (word >> 22) ^ word
}

/// PCG hash: one LCG step followed by the RXS-M-XS permutation. A bijection on `u32`.
#[inline]
pub fn pcg_hash(v: u32) -> u32 {
    rxs_m_xs(v.wrapping_mul(LCG_MULTIPLIER).wrapping_add(LCG_INCREMENT))
}

/// Hashes two words into one (order matters).
#[inline]
pub fn hash2(a: u32, b: u32) -> u32 {
    pcg_hash(pcg_hash(a) ^ b)
}

/// Bits of `x` with `-0.0` mapped to `+0.0`, so equal positions hash equally. (A comparison,
/// not `x + 0.0`, which a shader compiler may fold away.)
#[inline]
fn canonical_bits(x: f32) -> u32 {
    if x == 0.0 {
        0
    } else {
        x.to_bits()
    }
}

/// Hashes the bit patterns of a point's coordinates.
#[inline]
pub fn hash_vec3(p: Vec3) -> u32 {
    hash2(
        hash2(canonical_bits(p.x), canonical_bits(p.y)),
        canonical_bits(p.z),
    )
}

/// Seed of the bounce-map photon at `texel` (row-major index) of the light at `light_position`.
/// `global_seed` is the renderer's `--seed`.
#[inline]
pub fn seed_bounce_map_texel(light_position: Vec3, texel: u32, global_seed: u32) -> u32 {
    hash2(hash2(hash_vec3(light_position), texel), global_seed)
}

/// Seed of a CPU path that starts at `start` (the bounce-map photon's hit point).
#[inline]
pub fn seed_from_position(start: Vec3, global_seed: u32) -> u32 {
    hash2(hash_vec3(start), global_seed)
}

/// PCG RXS-M-XS 32/32: a tiny deterministic generator, identical to `rng.glsl`'s `Rng`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rng {
    state: u32,
}

impl Rng {
    /// A generator whose stream is determined by `seed` alone.
    pub fn new(seed: u32) -> Self {
        Self {
            state: pcg_hash(seed),
        }
    }

    /// Next 32 random bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(LCG_MULTIPLIER).wrapping_add(LCG_INCREMENT);
        rxs_m_xs(old)
    }

    /// Uniform in [0, 1): the top 24 bits scaled by 2⁻²⁴, exact in `f32` and never 1.
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Two uniform numbers.
    #[inline]
    pub fn next_2(&mut self) -> [f32; 2] {
        [self.next_f32(), self.next_f32()]
    }

    /// Three uniform numbers (the `u` of [`super::bsdf::Bsdf::sample`]).
    #[inline]
    pub fn next_3(&mut self) -> [f32; 3] {
        [self.next_f32(), self.next_f32(), self.next_f32()]
    }
}

/// `(v, pcg_hash(v))` pairs (computed by an independent Python model): the GPU test checks `rng.glsl` reproduces them.
pub const PCG_HASH_TEST_VECTORS: [(u32, u32); 6] = [
    (0, 129_708_002),
    (1, 2_831_084_092),
    (2, 2_055_130_248),
    (12_345, 4_099_845_390),
    (0x8000_0000, 566_699_590),
    (0xffff_ffff, 3_861_530_882),
];

/// The first four `next_u32` outputs of `Rng::new(seed)`, as `(seed, outputs)`.
pub const RNG_TEST_VECTORS: [(u32, [u32; 4]); 2] = [
    (0, [2_354_161_293, 817_759_070, 3_031_337_079, 619_535_985]),
    (42, [833_113_347, 2_785_308_739, 391_924_586, 3_212_367_989]),
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pcg_hash_matches_pinned_test_vectors() {
        for (v, h) in PCG_HASH_TEST_VECTORS {
            assert_eq!(pcg_hash(v), h, "pcg_hash({v})");
        }
    }

    #[test]
    fn rng_stream_matches_pinned_test_vectors() {
        for (seed, outs) in RNG_TEST_VECTORS {
            let mut rng = Rng::new(seed);
            let got = [0; 4].map(|_: u32| rng.next_u32());
            assert_eq!(got, outs, "seed {seed}");
        }
    }

    #[test]
    fn glsl_twin_carries_the_same_constants_and_test_vectors() {
        let glsl = include_str!("../../glsl/common/rng.glsl");
        for c in [LCG_MULTIPLIER, LCG_INCREMENT, RXS_M_XS_MULTIPLIER] {
            assert!(glsl.contains(&format!("{c}u")), "rng.glsl lacks {c}");
        }
        let outputs = PCG_HASH_TEST_VECTORS
            .iter()
            .map(|&(_, h)| h)
            .chain(RNG_TEST_VECTORS.iter().flat_map(|(_, o)| o.iter().copied()));
        for h in outputs {
            assert!(
                glsl.contains(&format!("{h}u")),
                "rng.glsl lacks test vector {h}"
            );
        }
    }

    #[test]
    fn same_seed_gives_same_stream_and_different_seeds_differ() {
        let (mut a, mut b, mut c) = (Rng::new(7), Rng::new(7), Rng::new(8));
        let mut differs = 0;
        for _ in 0..1000 {
            let x = a.next_u32();
            assert_eq!(x, b.next_u32());
            differs += usize::from(x != c.next_u32());
        }
        assert!(differs > 990);
    }

    #[test]
    fn position_seeds_are_frame_coherent_and_ignore_the_sign_of_zero() {
        let p = Vec3::new(1.5, -2.0, 0.0);
        assert_eq!(seed_from_position(p, 3), seed_from_position(p, 3));
        assert_eq!(
            seed_from_position(p, 3),
            seed_from_position(Vec3::new(1.5, -2.0, -0.0), 3)
        );
        assert_ne!(seed_from_position(p, 3), seed_from_position(p, 4));
        let l = Vec3::new(0.0, 5.0, 0.0);
        assert_ne!(
            seed_bounce_map_texel(l, 10, 0),
            seed_bounce_map_texel(l, 11, 0)
        );
        assert_ne!(
            seed_bounce_map_texel(l, 10, 0),
            seed_bounce_map_texel(l + Vec3::X * 1e-3, 10, 0)
        );
    }

    #[test]
    fn uniform_floats_fill_bins_evenly_and_stay_in_unit_interval() {
        // 64 bins, 640 000 draws: chi-square with 63 dof; 99.9% quantile ≈ 103.4.
        const BINS: usize = 64;
        const N: usize = 640_000;
        let mut rng = Rng::new(1234);
        let mut counts = [0u32; BINS];
        let mut sum = 0.0f64;
        for _ in 0..N {
            let u = rng.next_f32();
            assert!((0.0..1.0).contains(&u));
            sum += f64::from(u);
            counts[(u * BINS as f32) as usize] += 1;
        }
        let expected = (N / BINS) as f64;
        let chi2: f64 = counts
            .iter()
            .map(|&c| (f64::from(c) - expected).powi(2) / expected)
            .sum();
        assert!(chi2 < 103.4, "chi2 = {chi2}");
        assert!((sum / N as f64 - 0.5).abs() < 2e-3);
    }

    #[test]
    fn hashed_texel_seeds_have_balanced_bits() {
        // Each output bit over consecutive texels should be set about half the time.
        let l = Vec3::new(0.25, 3.0, -1.0);
        let n = 20_000u32;
        let mut ones = [0u32; 32];
        for t in 0..n {
            let s = seed_bounce_map_texel(l, t, 0);
            for (bit, count) in ones.iter_mut().enumerate() {
                *count += (s >> bit) & 1;
            }
        }
        for (bit, &c) in ones.iter().enumerate() {
            let f = f64::from(c) / f64::from(n);
            assert!((f - 0.5).abs() < 0.02, "bit {bit}: {f}");
        }
    }
}
