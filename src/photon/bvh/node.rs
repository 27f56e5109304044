//! The conservative CWBVH node test used inside obvhs's traversal (see the parent module's
//! docs on robustness).

use glam::{Vec3, Vec3A, Vec4};
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
    negative: [bool; 3],
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
        Self {
            origin: origin.into(),
            origin_abs: origin.abs().into(),
            inv_dir,
            inv_dir_abs: inv_dir.abs(),
            negative: [dir.x < 0.0, dir.y < 0.0, dir.z < 0.0],
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

/// Which children of `node` the ray's segment `[0, t_max]` may pass through, as obvhs's
/// traversal expects the mask (see the module docs): its quantized slab test, with each slab
/// widened by a bound on the rounding of `(p + q·extent − o) / d` computed as
/// `q·(extent/d) + (p − o)/d`, and of the box decompression itself.
#[inline(always)]
pub(super) fn intersect_node(node: &CwBvhNode, ray: &BoxRay, oct_inv4: u32) -> u32 {
    let extent = node.compute_extent();
    let p = Vec3A::from(node.p);
    let scale = extent * ray.inv_dir;
    let offset = (p - ray.origin) * ray.inv_dir;
    let err = gamma(8) * (p.abs() + ray.origin_abs + 255.0 * extent) * ray.inv_dir_abs;
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
    let mut hit_mask = 0;
    for half in 0..2 {
        let quad = |q: &[u8; 8]| {
            let i = half * 4;
            Vec4::new(
                q[i] as f32,
                q[i + 1] as f32,
                q[i + 2] as f32,
                q[i + 3] as f32,
            )
        };
        let near_far = |lo: &[u8; 8], hi: &[u8; 8], negative: bool| {
            if negative {
                (quad(hi), quad(lo))
            } else {
                (quad(lo), quad(hi))
            }
        };
        let (near_x, far_x) = near_far(&node.child_min_x, &node.child_max_x, ray.negative[0]);
        let (near_y, far_y) = near_far(&node.child_min_y, &node.child_max_y, ray.negative[1]);
        let (near_z, far_z) = near_far(&node.child_min_z, &node.child_max_z, ray.negative[2]);
        let t_near = (near_x * scale.x + (offset.x - err.x))
            .max(near_y * scale.y + (offset.y - err.y))
            .max(near_z * scale.z + (offset.z - err.z))
            .max(Vec4::ZERO);
        let t_far = (far_x * scale.x + (offset.x + err.x))
            .min(far_y * scale.y + (offset.y + err.y))
            .min(far_z * scale.z + (offset.z + err.z))
            .min(Vec4::splat(ray.t_max));
        let mask = t_near.cmple(t_far).bitmask();
        for j in 0..4 {
            if mask & (1 << j) != 0 {
                let child = half * 4 + j;
                hit_mask |= extract_byte64(child_bits8, child) << extract_byte64(bit_index8, child);
            }
        }
    }
    hit_mask
}
