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
#[inline(always)]
pub(super) fn intersect_node(node: &CwBvhNode, ray: &BoxRay, oct_inv4: u32) -> u32 {
    let extent = node.compute_extent();
    let p = Vec3A::from(node.p);
    let scale = extent * ray.inv_dir;
    let offset = (p - ray.origin) * ray.inv_dir;
    let err = gamma(8) * (p.abs() + ray.origin_abs + 255.0 * extent) * ray.inv_dir_abs;
    let planes = planes(node);
    let (near_offset, far_offset) = (offset - err, offset + err);
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
/// against `t_far = min(q_far·scale + far_offset, t_max)` over the three axes, the eight
/// children as eight lanes of one loop that the compiler vectorises.
#[inline(always)]
fn children_hit(
    planes: &[u64; 6],
    ray: &BoxRay,
    scale: Vec3A,
    near_offset: Vec3A,
    far_offset: Vec3A,
) -> u32 {
    // SSE's `maxps`/`minps` (and glam's `Vec4::max`/`min`, which this test used): the second
    // operand unless the first is strictly greater (smaller), so NaNs fall as they did.
    let max = |a: f32, b: f32| if a > b { a } else { b };
    let min = |a: f32, b: f32| if a < b { a } else { b };
    let bytes = planes.map(u64::to_le_bytes);
    let t = |a: usize, planes_of: &[usize; 3], offset: Vec3A, child: usize| {
        f32::from(bytes[planes_of[a]][child]) * scale[a] + offset[a]
    };
    let mut mask = 0;
    // Eight independent lanes: the compiler vectorises the loop, eight wide where the CPU
    // has AVX2 (`intersect_fastest`'s copy), four wide twice otherwise.
    for child in 0..8 {
        let near = max(
            max(
                max(
                    t(0, &ray.near, near_offset, child),
                    t(1, &ray.near, near_offset, child),
                ),
                t(2, &ray.near, near_offset, child),
            ),
            0.0,
        );
        let far = min(
            min(
                min(
                    t(0, &ray.far, far_offset, child),
                    t(1, &ray.far, far_offset, child),
                ),
                t(2, &ray.far, far_offset, child),
            ),
            ray.t_max,
        );
        mask |= u32::from(near <= far) << child;
    }
    mask
}
