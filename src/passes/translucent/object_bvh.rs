//! Each delta mesh's own triangles in a BVH the translucent shader traces: what a ray meets of
//! its own object after the object reflected or refracted it (the far side of a glass, a
//! ring's inner wall seen in the other, total internal reflection), before it leaves the
//! object and looks the environment cube up (`translucent.frag`, `follow`).
//!
//! ```text
//!   eye ──► glass front ──refract──► own BVH: back face ──refract──► environment cube
//!                                                └─ or reflect (TIR) ─► own BVH again …
//! ```
//!
//! Object space, built once per mesh on the CPU (an instance's transform reaches the shader as
//! its model matrix, so a moving glass does not rebuild it): nodes split at the median
//! centroid of their longest axis, leaves of at most [`LEAF_SIZE`] triangles; an inner node's
//! two children are next to each other. All meshes' trees share one node and one triangle
//! array; `DrawPush::material.z` is 1 + the draw's root (0: the mesh has none).

use crate::layout::{ObjectNode, ObjectTriangle};
use crate::scene::Mesh;
use glam::Vec3;

/// Most triangles in a leaf.
pub const LEAF_SIZE: usize = 4;

/// The trees of some meshes, in one node and one triangle array.
#[derive(Default)]
pub struct ObjectBvhs {
    pub nodes: Vec<ObjectNode>,
    pub triangles: Vec<ObjectTriangle>,
}

impl ObjectBvhs {
    /// Adds `mesh`'s tree; returns its root's index. `mesh` must have triangles (the caller
    /// gives a mesh without any no tree: it draws nothing).
    pub fn add(&mut self, mesh: &Mesh) -> u32 {
        debug_assert!(!mesh.triangles.is_empty());
        let first_triangle = self.triangles.len();
        let triangles: Vec<ObjectTriangle> = mesh
            .triangles
            .iter()
            .map(|t| object_triangle(mesh, *t))
            .collect();
        let root = self.nodes.len();
        self.nodes.push(ObjectNode::default());
        let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
        let centroids: Vec<Vec3> = triangles
            .iter()
            .map(|t| (t.p0 + t.p1 + t.p2).truncate() / 3.0)
            .collect();
        self.fill(
            root,
            &mut order,
            (0, 0),
            &triangles,
            &centroids,
            first_triangle,
        );
        self.triangles
            .extend(order.iter().map(|&i| triangles[i as usize]));
        root as u32
    }

    /// Makes node `node`, `depth` below the root, over `order` (indices into `triangles`,
    /// which start at `offset` in the shared array once placed in `order`'s order; `start` is
    /// `order`'s position there).
    fn fill(
        &mut self,
        node: usize,
        order: &mut [u32],
        (start, depth): (usize, usize),
        triangles: &[ObjectTriangle],
        centroids: &[Vec3],
        offset: usize,
    ) {
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        let (mut c_lo, mut c_hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for &i in order.iter() {
            let t = &triangles[i as usize];
            for p in [t.p0, t.p1, t.p2] {
                lo = lo.min(p.truncate());
                hi = hi.max(p.truncate());
            }
            c_lo = c_lo.min(centroids[i as usize]);
            c_hi = c_hi.max(centroids[i as usize]);
        }
        let extent = c_hi - c_lo;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        // The shader's traversal stack (OBJECT_STACK in translucent.frag) holds 32: a median
        // split is log2(triangles) deep.
        debug_assert!(depth < 32, "an object BVH {depth} deep");
        // A leaf: few triangles, or centroids that no plane separates.
        if order.len() <= LEAF_SIZE || extent[axis].is_nan() || extent[axis] <= 0.0 {
            self.nodes[node] = ObjectNode {
                lo: lo.to_array(),
                first: (offset + start) as u32,
                hi: hi.to_array(),
                count: order.len() as u32,
            };
            return;
        }
        let mid = order.len() / 2;
        order.select_nth_unstable_by(mid, |&a, &b| {
            centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis])
        });
        let first_child = self.nodes.len();
        self.nodes.push(ObjectNode::default());
        self.nodes.push(ObjectNode::default());
        self.nodes[node] = ObjectNode {
            lo: lo.to_array(),
            first: first_child as u32,
            hi: hi.to_array(),
            count: 0,
        };
        let (left, right) = order.split_at_mut(mid);
        self.fill(
            first_child,
            left,
            (start, depth + 1),
            triangles,
            centroids,
            offset,
        );
        self.fill(
            first_child + 1,
            right,
            (start + mid, depth + 1),
            triangles,
            centroids,
            offset,
        );
    }
}

/// Triangle `t` of `mesh` with its vertices' normals (the face's where the mesh has none, or
/// a zero one).
fn object_triangle(mesh: &Mesh, t: [u32; 3]) -> ObjectTriangle {
    let p = t.map(|i| {
        mesh.positions
            .get(i as usize)
            .copied()
            .unwrap_or(Vec3::ZERO)
    });
    let face = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
    let n = t.map(|i| {
        mesh.normals
            .get(i as usize)
            .copied()
            .filter(|n| n.length_squared() > 0.0)
            .unwrap_or(face)
    });
    ObjectTriangle {
        p0: p[0].extend(0.0),
        p1: p[1].extend(0.0),
        p2: p[2].extend(0.0),
        n0: n[0].extend(0.0),
        n1: n[1].extend(0.0),
        n2: n[2].extend(0.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::rng::Rng;

    /// The closest hit by walking the tree as the shader does (a stack, both children of an
    /// inner node), against every triangle by brute force.
    fn walk(bvhs: &ObjectBvhs, root: u32, o: Vec3, d: Vec3) -> Option<(f32, u32)> {
        let mut best: Option<(f32, u32)> = None;
        let mut stack = vec![root];
        while let Some(n) = stack.pop() {
            let node = bvhs.nodes[n as usize];
            let (lo, hi) = (Vec3::from(node.lo), Vec3::from(node.hi));
            let inv = d.recip();
            let (t0, t1) = ((lo - o) * inv, (hi - o) * inv);
            let near = t0.min(t1).max_element().max(0.0);
            let far = t0
                .max(t1)
                .min_element()
                .min(best.map_or(f32::INFINITY, |b| b.0));
            if near > far {
                continue;
            }
            let (first, count) = (node.first, node.count);
            if count == 0 {
                stack.extend([first, first + 1]);
                continue;
            }
            for i in first..first + count {
                if let Some(t) = hit(&bvhs.triangles[i as usize], o, d) {
                    if best.is_none_or(|b| t < b.0) {
                        best = Some((t, i));
                    }
                }
            }
        }
        best
    }

    fn hit(t: &ObjectTriangle, o: Vec3, d: Vec3) -> Option<f32> {
        let (a, b, c) = (t.p0.truncate(), t.p1.truncate(), t.p2.truncate());
        let (e1, e2) = (b - a, c - a);
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-12 {
            return None;
        }
        let s = o - a;
        let u = s.dot(p) / det;
        let q = s.cross(e1);
        let v = d.dot(q) / det;
        let t = e2.dot(q) / det;
        (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0).then_some(t)
    }

    /// The bundled `glass-cube`'s delta meshes (its 12-triangle cube and its ball) in one pair
    /// of arrays: every triangle once in its own tree, every node's bounds holding its
    /// triangles, and the tree's closest hit the brute-force one along 500 random rays from
    /// inside and outside each.
    #[test]
    fn the_trees_hold_every_triangle_once_and_find_the_closest_hit() {
        let scene = crate::scene::bundled::resolve(Some("glass-cube")).expect("bundled scene");
        let meshes: Vec<&Mesh> = scene
            .meshes
            .iter()
            .filter(|m| scene.materials[m.material].has_delta_lobe())
            .collect();
        assert_eq!(meshes.len(), 2);
        let mut bvhs = ObjectBvhs::default();
        let roots: Vec<u32> = meshes.iter().map(|m| bvhs.add(m)).collect();
        let counts: Vec<u32> = meshes.iter().map(|m| m.triangles.len() as u32).collect();
        assert_eq!(counts[0] + counts[1], bvhs.triangles.len() as u32);
        assert!(
            counts.contains(&12) && counts.iter().any(|&c| c > 1000),
            "{counts:?}"
        );
        let mut rng = Rng::new(9);
        let ranges = [0..counts[0], counts[0]..counts[0] + counts[1]];
        for ((root, mesh), range) in roots.iter().zip(&meshes).zip(ranges) {
            let centre = mesh.positions.iter().copied().sum::<Vec3>() / mesh.positions.len() as f32;
            let size = mesh
                .positions
                .iter()
                .map(|p| p.distance(centre))
                .fold(0.0, f32::max);
            // Every triangle in exactly one leaf of its tree, inside every node's bounds above.
            let mut seen = vec![0; bvhs.triangles.len()];
            let mut stack = vec![(*root, Vec3::NEG_INFINITY, Vec3::INFINITY)];
            while let Some((n, plo, phi)) = stack.pop() {
                let node = bvhs.nodes[n as usize];
                let (lo, hi) = (Vec3::from(node.lo), Vec3::from(node.hi));
                assert!(
                    lo.cmpge(plo).all() && hi.cmple(phi).all(),
                    "child outside parent"
                );
                let (first, count) = (node.first, node.count);
                if count == 0 {
                    stack.extend([(first, lo, hi), (first + 1, lo, hi)]);
                    continue;
                }
                assert!(count as usize <= LEAF_SIZE, "a leaf of {count}");
                for i in first..first + count {
                    seen[i as usize] += 1;
                    let t = &bvhs.triangles[i as usize];
                    for p in [t.p0, t.p1, t.p2] {
                        assert!(p.truncate().cmpge(lo).all() && p.truncate().cmple(hi).all());
                    }
                }
            }
            for i in range.clone() {
                assert_eq!(seen[i as usize], 1, "triangle {i}");
            }
            let mut unit = || rng.next_f32() * 2.0 - 1.0;
            let mut hits = 0;
            for k in 0..500 {
                let spread = if k % 2 == 0 { 0.4 * size } else { 3.0 * size };
                let o = centre + Vec3::new(unit(), unit(), unit()) * spread;
                let d = (Vec3::new(unit(), unit(), unit()) * size + centre - o).normalize();
                let brute = range
                    .clone()
                    .filter_map(|i| hit(&bvhs.triangles[i as usize], o, d).map(|t| (t, i)))
                    .min_by(|a, b| a.0.total_cmp(&b.0));
                let tree = walk(&bvhs, *root, o, d);
                assert_eq!(tree.map(|h| h.0), brute.map(|h| h.0), "ray {k}");
                hits += usize::from(tree.is_some());
            }
            assert!(hits > 250, "{hits} of 500 rays hit");
        }
    }
}
