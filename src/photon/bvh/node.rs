//! The conservative CWBVH node test used inside obvhs's traversal (see the parent module's
//! docs on robustness).

use glam::{Vec3, Vec3A};
use obvhs::cwbvh::node::{extract_byte64, CwBvhNode};

use crate::photon::ray::gamma;

/// Largest `|1 / dir|` per component in the node test.
const MAX_INV_DIR: f32 = (1u64 << 40) as f32;

/// A ray prepared for the conservative node test.
pub(super) struct BoxRay {
    origin: Vec3A,
    origin_abs: Vec3A,
    inv_dir: Vec3A,
    inv_dir_abs: Vec3A,
    /// Per axis, which of the node's eight-byte plane arrays (`child_min_x`, `child_max_x`,
    /// `child_min_y`, …, in the node's layout) holds the near and which the far planes.
    near: [usize; 3],
    far: [usize; 3],
    t_max: f32,
}

impl BoxRay {
    pub(super) fn new(origin: Vec3, dir: Vec3, t_max: f32) -> Self {
        // The sign convention (−0 counts as positive) matches obvhs's child ordering.
        let inv = |d: f32| {
            let inv = 1.0 / d;
            if inv.is_finite() && inv.abs() <= MAX_INV_DIR {
                inv
            } else if d < 0.0 {
                -MAX_INV_DIR
            } else {
                MAX_INV_DIR
            }
        };
        let inv_dir = Vec3A::new(inv(dir.x), inv(dir.y), inv(dir.z));
        let negative = [dir.x < 0.0, dir.y < 0.0, dir.z < 0.0];
        Self {
            origin: origin.into(),
            origin_abs: origin.abs().into(),
            inv_dir,
            inv_dir_abs: inv_dir.abs(),
            near: [0, 1, 2].map(|a| 2 * a + negative[a] as usize),
            far: [0, 1, 2].map(|a| 2 * a + !negative[a] as usize),
            t_max: 0.0,
        }
        .with_t_max(t_max)
    }

    fn with_t_max(mut self, t_max: f32) -> Self {
        self.set_t_max(t_max);
        self
    }

    pub(super) fn set_t_max(&mut self, t_max: f32) {
        self.t_max = t_max * (1.0 + 2.0 * gamma(3));
    }
}

/// The node's six quantized plane arrays (`child_min_x` … `child_max_z`), each as a `u64`.
#[inline(always)]
fn planes(node: &CwBvhNode) -> [u64; 6] {
    [
        u64::from_le_bytes(node.child_min_x),
        u64::from_le_bytes(node.child_max_x),
        u64::from_le_bytes(node.child_min_y),
        u64::from_le_bytes(node.child_max_y),
        u64::from_le_bytes(node.child_min_z),
        u64::from_le_bytes(node.child_max_z),
    ]
}

/// Which children of `node` the ray's segment `[0, t_max]` may pass through, as obvhs's
/// traversal expects the mask (see the module docs): its quantized slab test, with each slab
/// widened by a bound on the rounding of `(p + q·extent − o) / d` computed as
/// `q·(extent/d) + (p − o)/d`, and of the box decompression itself. The near and far planes of
/// each axis are picked by the ray's direction signs (precomputed in [`BoxRay`]), and the eight
/// children are tested four at a time.
///
/// With `AVX2` the eight children are tested at once in 256-bit registers, with the same
/// operations in the same order (the same mask bit for bit).
///
/// # Safety
/// With `AVX2`, the CPU must support AVX2.
#[inline(always)]
pub(super) unsafe fn intersect_node<const AVX2: bool>(
    node: &CwBvhNode,
    ray: &BoxRay,
    oct_inv4: u32,
) -> u32 {
    let extent = node.compute_extent();
    let p = Vec3A::from(node.p);
    let scale = extent * ray.inv_dir;
    let offset = (p - ray.origin) * ray.inv_dir;
    let err = gamma(8) * (p.abs() + ray.origin_abs + 255.0 * extent) * ray.inv_dir_abs;
    let planes = planes(node);
    let (near_offset, far_offset) = (offset - err, offset + err);
    #[cfg(target_arch = "x86_64")]
    let mut children = if AVX2 {
        // SAFETY: with `AVX2` the caller guarantees the CPU supports AVX2.
        unsafe { children_hit_avx2(&planes, ray, scale, near_offset, far_offset) }
    } else {
        children_hit(&planes, ray, scale, near_offset, far_offset)
    };
    #[cfg(not(target_arch = "x86_64"))]
    let mut children = children_hit(&planes, ray, scale, near_offset, far_offset);
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
    let mut hit_mask = 0;
    while children != 0 {
        let child = children.trailing_zeros() as usize;
        children &= children - 1;
        hit_mask |= extract_byte64(child_bits8, child) << extract_byte64(bit_index8, child);
    }
    hit_mask
}

/// Bit `i` set when child `i`'s slabs overlap: `t_near = max(q_near·scale + near_offset, 0)`
/// against `t_far = min(q_far·scale + far_offset, t_max)` over the three axes, four children
/// at a time (glam's `Vec4`; LLVM widens the bytes with SIMD unpacks).
#[inline(always)]
fn children_hit(
    planes: &[u64; 6],
    ray: &BoxRay,
    scale: Vec3A,
    near_offset: Vec3A,
    far_offset: Vec3A,
) -> u32 {
    use glam::Vec4;
    let quad = |bytes: u64, half: usize| {
        let b = bytes.to_le_bytes();
        let i = 4 * half;
        Vec4::new(
            b[i] as f32,
            b[i + 1] as f32,
            b[i + 2] as f32,
            b[i + 3] as f32,
        )
    };
    let mut mask = 0;
    for half in 0..2 {
        let t = |a: usize, planes_of: &[usize; 3], offset: Vec3A| {
            quad(planes[planes_of[a]], half) * scale[a] + offset[a]
        };
        let t_near = t(0, &ray.near, near_offset)
            .max(t(1, &ray.near, near_offset))
            .max(t(2, &ray.near, near_offset))
            .max(Vec4::ZERO);
        let t_far = t(0, &ray.far, far_offset)
            .min(t(1, &ray.far, far_offset))
            .min(t(2, &ray.far, far_offset))
            .min(Vec4::splat(ray.t_max));
        mask |= t_near.cmple(t_far).bitmask() << (4 * half);
    }
    mask
}

/// [`children_hit`] for all eight children at once with AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn children_hit_avx2(
    planes: &[u64; 6],
    ray: &BoxRay,
    scale: Vec3A,
    near_offset: Vec3A,
    far_offset: Vec3A,
) -> u32 {
    use std::arch::x86_64::*;
    macro_rules! t {
        ($planes_of:expr, $offset:expr, $a:expr) => {{
            let bytes = _mm_cvtsi64_si128(planes[$planes_of[$a]] as i64);
            let q = _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(bytes));
            _mm256_add_ps(
                _mm256_mul_ps(q, _mm256_set1_ps(scale[$a])),
                _mm256_set1_ps($offset[$a]),
            )
        }};
    }
    let t_near = _mm256_max_ps(
        _mm256_max_ps(
            _mm256_max_ps(t!(ray.near, near_offset, 0), t!(ray.near, near_offset, 1)),
            t!(ray.near, near_offset, 2),
        ),
        _mm256_setzero_ps(),
    );
    let t_far = _mm256_min_ps(
        _mm256_min_ps(
            _mm256_min_ps(t!(ray.far, far_offset, 0), t!(ray.far, far_offset, 1)),
            t!(ray.far, far_offset, 2),
        ),
        _mm256_set1_ps(ray.t_max),
    );
    _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t_near, t_far)) as u32
}
