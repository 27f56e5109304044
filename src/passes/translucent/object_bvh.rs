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
//!
//! # Convex meshes
//! A ray that leaves a convex object through the plane of the face it starts on meets no more
//! of it, so the shader skips the traversal for it ([`convex_centre`] decides which meshes are
//! convex enough for that; `translucent.frag`, `leaves_convex`). A glass ball seen from
//! outside traces three rays per pixel (the reflection, the refraction in, the refraction out
//! at the far side); two of them leave it.
//! `DrawPush::material.w` is 1 for a convex mesh, and `normal0.w`, `normal1.w`, `normal2.w`
//! hold its centre (object space), which tells the shader which side of a face is outside.
//! Convex meshes are drawn with a pipeline of their own (`SPEC_ID_CONVEX_SHORTCUT`); the
//! others' pipeline has the test compiled out, so they pay nothing for it. The rays of a convex
//! mesh that are traversed start on its surface, and a line meets a convex surface at most
//! twice, so their traversal ends at the first hit found (`object_hit`'s `first_hit`).
//! The test uses the faces' planes, not the interpolated normals: a reflection about a
//! shading normal can point into the geometric surface, and such a ray does meet the object
//! again.

use crate::layout::{ObjectNode, ObjectTriangle};
use crate::scene::Mesh;
use glam::{DVec3, Vec3};
use std::collections::HashSet;

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

/// Most vertex–face pairs [`convex_centre`] checks: a mesh with more is taken as not convex
/// (the shader then traverses every ray, as before). 2·10⁸ is a 20 000-triangle ball, about
/// 0.2 s of checking once per scene (~1 ns a pair); glass-sphere's 5120-triangle ball takes
/// 13 ms.
pub const CONVEX_CHECK_MAX: usize = 200_000_000;

/// The centre of `mesh`'s vertices (object space) when every vertex lies behind or on the plane
/// of every face, seen from that centre, which itself lies strictly behind each (10⁻⁵ of the
/// mesh's size is "on"); `None` otherwise.
///
/// That is exactly what the shader's shortcut needs (`translucent.frag`, `leaves_convex`): every
/// triangle lies in the vertices' convex hull, so behind every face's plane, and a ray that
/// leaves a face through its plane, away from the centre, meets none of them. A closed mesh
/// passes when it bounds a convex body, an open one when it is a piece of such a boundary (a
/// dome); a dent, a second piece or a surface that winds round twice puts some vertex in
/// front of some face. Degenerate triangles have no plane to leave through: the shader never
/// skips from one, and they are not checked. The check is one pass over the vertices per face
/// (vertices welded by position first), at most [`CONVEX_CHECK_MAX`] pairs.
pub fn convex_centre(mesh: &Mesh) -> Option<Vec3> {
    let mut seen: HashSet<[u32; 3]> = HashSet::new();
    let mut vertices: Vec<Vec3> = Vec::new();
    for &i in mesh.triangles.iter().flatten() {
        let p = *mesh.positions.get(i as usize)?;
        if !p.is_finite() {
            return None;
        }
        // + 0.0 turns −0.0 into +0.0, so that the two weld.
        if seen.insert((p + Vec3::ZERO).to_array().map(f32::to_bits)) {
            vertices.push(p);
        }
    }
    if vertices.is_empty() || vertices.len().saturating_mul(mesh.triangles.len()) > CONVEX_CHECK_MAX
    {
        return None;
    }
    let sum: DVec3 = vertices.iter().map(|p| p.as_dvec3()).sum();
    let centre = (sum / vertices.len() as f64).as_vec3();
    let size = vertices
        .iter()
        .map(|p| p.distance(centre))
        .fold(0.0, f32::max);
    let tolerance = 1e-5 * size;
    let convex = mesh.triangles.iter().all(|t| {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        let n = (b - a).cross(c - a).normalize_or_zero();
        if n == Vec3::ZERO {
            return true;
        }
        // n turned to point away from the centre: "in front" is outside.
        let n = if n.dot(centre - a) < 0.0 { n } else { -n };
        n.dot(centre - a) < -tolerance && vertices.iter().all(|&v| n.dot(v - a) <= tolerance)
    });
    convex.then_some(centre)
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

    fn delta_meshes(scene: &str) -> Vec<Mesh> {
        let scene = crate::scene::bundled::resolve(Some(scene)).expect("bundled scene");
        scene
            .meshes
            .iter()
            .filter(|m| scene.materials[m.material].has_delta_lobe())
            .cloned()
            .collect()
    }

    #[test]
    fn convex_meshes_are_told_from_the_rest() {
        let ball = crate::photon::shapes::icosphere(3);
        let centre = convex_centre(&ball).expect("a ball is convex");
        assert!(centre.length() < 1e-5, "{centre}");
        // Wound inwards, or with its vertices split per triangle (flat shading): still convex.
        let mut inward = ball.clone();
        inward.triangles.iter_mut().for_each(|t| t.swap(1, 2));
        assert!(convex_centre(&inward).is_some());
        let mut split = ball.clone();
        split.positions = ball
            .triangles
            .iter()
            .flatten()
            .map(|&i| ball.positions[i as usize])
            .collect();
        split.triangles = (0..ball.triangles.len() as u32)
            .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
            .collect();
        assert!(convex_centre(&split).is_some());
        // Moved off the origin and stretched: the centre moves with it.
        let mut moved = ball.clone();
        moved
            .positions
            .iter_mut()
            .for_each(|p| *p = *p * Vec3::new(3.0, 0.5, 1.0) + 7.0);
        assert!(
            convex_centre(&moved)
                .expect("convex")
                .distance(Vec3::splat(7.0))
                < 1e-4
        );
        // The bundled glass: glass-cube's cube (split faces: coplanar edges) and ball, and
        // glass-sphere's ball, are convex; caustic-ring's ring is not.
        for scene in ["glass-cube", "glass-sphere"] {
            for m in delta_meshes(scene) {
                assert!(convex_centre(&m).is_some(), "{scene}: {}", m.name);
            }
        }
        let ring = delta_meshes("caustic-ring");
        assert!(!ring.is_empty() && ring.iter().all(|m| convex_centre(m).is_none()));
        // Not convex: a dent, a second ball beside or inside, a shallow bowl made of many small
        // faces (each edge nearly flat), a surface that winds round twice; convex: a dome.
        let mut dented = ball.clone();
        dented.positions[0] *= 0.8;
        assert!(convex_centre(&dented).is_none(), "dent");
        let with = |offset: Vec3, scale: f32| {
            let mut two = ball.clone();
            let n = ball.positions.len() as u32;
            two.positions
                .extend(ball.positions.iter().map(|p| *p * scale + offset));
            two.triangles
                .extend(ball.triangles.iter().map(|t| t.map(|i| i + n)));
            two
        };
        assert!(
            convex_centre(&with(Vec3::X * 3.0, 1.0)).is_none(),
            "two balls"
        );
        assert!(
            convex_centre(&with(Vec3::ZERO, 0.5)).is_none(),
            "a ball in a ball"
        );
        // A slab 60 wide and 1 thick whose top is a bowl 0.18 deep at the corners, made of
        // 7200 small faces: each edge bends by less than the tolerance, the whole does not.
        // With a dome on top instead, the slab is convex. (Its sides are left open: the check
        // needs no closed mesh.)
        let slab = |curve: f32| {
            let mut top = crate::photon::shapes::grid(60, |x, z| {
                curve * ((x - 30.0).powi(2) + (z - 30.0).powi(2))
            });
            let bottom = crate::photon::shapes::grid(60, |_, _| -1.0);
            let n = top.positions.len() as u32;
            top.positions.extend(&bottom.positions);
            top.triangles
                .extend(bottom.triangles.iter().map(|t| t.map(|i| i + n)));
            top
        };
        assert!(
            convex_centre(&slab(1e-4)).is_none(),
            "a slab with a shallow bowl on top"
        );
        assert!(
            convex_centre(&slab(-1e-4)).is_some(),
            "a slab with a dome on top"
        );
        // A bipyramid whose rim is joined in pentagram order: every edge paired and convex,
        // the centre behind every face, yet it winds round its axis twice.
        let rim = (0..5).map(|k| {
            let a = std::f32::consts::TAU * (2 * k) as f32 / 5.0;
            Vec3::new(a.cos(), 0.0, a.sin())
        });
        let star = Mesh {
            positions: [Vec3::Y, -Vec3::Y].into_iter().chain(rim).collect(),
            triangles: (0..5u32)
                .flat_map(|k| [[0, 2 + (k + 1) % 5, 2 + k], [1, 2 + k, 2 + (k + 1) % 5]])
                .collect(),
            ..Mesh::default()
        };
        assert!(convex_centre(&star).is_none(), "pentagram bipyramid");
        // Convex all the same: a hole (the rest is a piece of a convex boundary), a triangle
        // wound the other way (the shader goes by the centre, not the winding), a split vertex,
        // a degenerate triangle (skipped: no plane to leave through).
        let mut open = ball.clone();
        open.triangles.pop();
        assert!(convex_centre(&open).is_some(), "hole");
        let mut flipped = ball.clone();
        flipped.triangles[5].swap(1, 2);
        assert!(
            convex_centre(&flipped).is_some(),
            "one triangle wound the other way"
        );
        let mut flat = ball.clone();
        flat.positions
            .push(ball.positions[ball.triangles[0][1] as usize]);
        let last = flat.positions.len() as u32 - 1;
        flat.triangles[0][1] = last;
        assert!(convex_centre(&flat).is_some(), "a split vertex");
        flat.triangles[0][1] = flat.triangles[0][0];
        assert!(convex_centre(&flat).is_some(), "degenerate triangle");
    }

    /// `translucent.frag`'s `leaves_convex`.
    fn leaves_convex(d: Vec3, face: Vec3, to_centre: Vec3) -> bool {
        let along = d.dot(face);
        along * to_centre.dot(face) < 0.0 && along.abs() > 1e-4 * d.length() * face.length()
    }

    /// Rays from random points of random faces in random directions: of those the shader's
    /// test lets leave, how many meet the mesh again (brute force, past a small distance).
    fn leaving_rays_that_hit(mesh: &Mesh, centre: Vec3, rays: usize) -> (usize, usize) {
        let mut bvhs = ObjectBvhs::default();
        bvhs.add(mesh);
        let size = mesh
            .positions
            .iter()
            .map(|p| p.distance(centre))
            .fold(0.0, f32::max);
        let mut rng = Rng::new(17);
        let (mut leaving, mut hit_again) = (0, 0);
        for _ in 0..rays {
            let i = (rng.next_u32() as usize) % bvhs.triangles.len();
            let t = &bvhs.triangles[i];
            let (a, b, c) = (t.p0.truncate(), t.p1.truncate(), t.p2.truncate());
            let (mut u, mut v) = (rng.next_f32(), rng.next_f32());
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            let p = a + u * (b - a) + v * (c - a);
            let d = crate::photon::sampling::uniform_sphere(rng.next_2());
            let face = (b - a).cross(c - a);
            if !leaves_convex(d, face, centre - p) {
                continue;
            }
            leaving += 1;
            let again = (0..bvhs.triangles.len())
                .filter(|&j| j != i)
                .filter_map(|j| hit(&bvhs.triangles[j], p, d))
                .any(|t| t > 1e-4 * size);
            hit_again += usize::from(again);
        }
        (leaving, hit_again)
    }

    #[test]
    fn a_ray_the_shader_lets_leave_a_convex_mesh_meets_no_more_of_it() {
        // The bundled convex glass: no ray through its face's plane away from the centre meets
        // it again, so skipping the traversal changes nothing.
        for scene in ["glass-cube", "glass-sphere"] {
            for m in delta_meshes(scene) {
                let centre = convex_centre(&m).expect("convex");
                let (leaving, again) = leaving_rays_that_hit(&m, centre, 4000);
                assert!(
                    leaving > 1500,
                    "{scene} {}: {leaving} of 4000 leave",
                    m.name
                );
                assert_eq!(again, 0, "{scene} {}", m.name);
            }
        }
        // The same test on caustic-ring's ring (not convex, so the shader never applies it
        // there) does find rays that meet the ring again: the check above can fail.
        for m in delta_meshes("caustic-ring") {
            let centre = m.positions.iter().copied().sum::<Vec3>() / m.positions.len() as f32;
            let (_, again) = leaving_rays_that_hit(&m, centre, 4000);
            assert!(again > 0, "{}", m.name);
        }
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
