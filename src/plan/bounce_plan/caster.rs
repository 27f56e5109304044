//! The casters: the instances whose material has a delta lobe (mirror, glass), and the
//! rectangle of a light view that holds their projection, where the plan puts a caustic view
//! (module docs, "Caustic views").

use crate::scene::{Aabb, Scene};
use glam::{DMat4, DVec2, DVec3, DVec4};

/// An instance whose material has a delta lobe: its world-space vertices and their box.
#[derive(Clone, Debug)]
pub struct Caster {
    pub vertices: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
    pub bounds: Aabb,
}

impl Caster {
    /// Its vertices in the clip space of the view `m` (`origin`-relative world → clip).
    pub(super) fn clip(&self, m: &DMat4, origin: DVec3) -> Vec<DVec4> {
        self.vertices
            .iter()
            .map(|p| *m * (*p - origin).extend(1.0))
            .collect()
    }
}

/// The instances of `scene` whose material has a delta lobe (mirror, glass).
pub fn casters(scene: &Scene) -> Vec<Caster> {
    let mut out = Vec::new();
    for inst in &scene.instances {
        let Some(mesh) = scene.meshes.get(inst.mesh) else {
            continue;
        };
        let delta = scene
            .materials
            .get(mesh.material)
            .is_some_and(|m| m.has_delta_lobe());
        if !delta || mesh.positions.is_empty() {
            continue;
        }
        let transform = inst.transform.as_dmat4();
        let vertices: Vec<DVec3> = mesh
            .positions
            .iter()
            .map(|p| transform.transform_point3(p.as_dvec3()))
            .collect();
        let mut bounds = Aabb::EMPTY;
        for p in &vertices {
            bounds.grow(p.as_vec3());
        }
        out.push(Caster {
            vertices,
            triangles: mesh.triangles.clone(),
            bounds,
        });
    }
    out
}

/// The NDC rectangle of the view `m` (origin-relative world → clip) holding the projection of
/// every caster, clamped to the view; `None` if none of them is in it. A caster wholly in front
/// of the light's eye plane is bounded by its projected vertices (the mesh's convex hull); one
/// reaching behind a perspective light by its box, whose edges are cut at w = ε, so that the
/// rectangle widens to the view's edge instead of folding over.
pub(super) fn caster_rect(m: &DMat4, casters: &[Caster], origin: DVec3) -> Option<(DVec2, DVec2)> {
    const EPS: f64 = 1e-9;
    let mut lo = DVec2::splat(f64::INFINITY);
    let mut hi = DVec2::splat(f64::NEG_INFINITY);
    let mut add = |c: DVec4| {
        let p = DVec2::new(c.x, c.y) / c.w;
        lo = lo.min(p);
        hi = hi.max(p);
    };
    for caster in casters {
        let clip = caster.clip(m, origin);
        if clip.iter().all(|c| c.w > EPS) {
            clip.into_iter().for_each(&mut add);
            continue;
        }
        let (min, max) = (caster.bounds.min.as_dvec3(), caster.bounds.max.as_dvec3());
        let corners: [DVec4; 8] = std::array::from_fn(|i| {
            let p = DVec3::new(
                if i & 1 == 0 { min.x } else { max.x },
                if i & 2 == 0 { min.y } else { max.y },
                if i & 4 == 0 { min.z } else { max.z },
            );
            *m * (p - origin).extend(1.0)
        });
        for (i, a) in corners.iter().enumerate() {
            if a.w > EPS {
                add(*a);
            }
            for bit in [1, 2, 4] {
                if i & bit != 0 {
                    continue;
                }
                let b = corners[i | bit];
                if (a.w > EPS) != (b.w > EPS) {
                    let t = (EPS - a.w) / (b.w - a.w);
                    add(*a + (b - *a) * t);
                }
            }
        }
    }
    let (lo, hi) = (lo.max(DVec2::NEG_ONE), hi.min(DVec2::ONE));
    (lo.x < hi.x && lo.y < hi.y).then_some((lo, hi))
}
