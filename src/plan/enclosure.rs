//! Closed opaque surfaces, and which points they provably separate: a light inside a closed
//! box the camera is outside of lights nothing the camera sees.
//!
//! The scene's world triangles are welded by exact position (instances that share corners
//! weld too) and split into connected surfaces. A surface is **closed** when every edge is
//! used by an even number of its triangles (a closed 2-chain mod 2: the parity of a ray's
//! crossings then tells inside from outside, whatever the winding), and **opaque** when none of
//! its materials refracts. A point's side is the parity of the crossings of three rays in
//! fixed, axis-skew directions, traced with the photon tracer's watertight intersection; a
//! ray that meets an edge or vertex exactly (a barycentric of exactly 0, where two triangles
//! may both count) is discarded. The side is *unknown* unless at least two rays remain and
//! agree, or when the point lies within its clearance of the surface: unknown never
//! separates, so every doubt keeps the light on.
//!
//! **Moving instances.** Welding is the costly part (a hash of every world vertex, linear in the
//! scene's triangles), and a frame in which instances move would redo it
//! for the whole scene. [`StaticEnclosures`] welds the instances that do not move once;
//! [`Enclosures::with_static`] then welds the moving ones alone and adds their surfaces, which
//! is exact while no moving vertex lands exactly on a static one (a surface would then span
//! both): then, and only then, it welds everything again.

use crate::photon::bsdf::MaterialLobes;
use crate::photon::triangle::WatertightRay;
use crate::scene::{Aabb, Material, Scene};
use glam::Vec3;
use std::collections::HashMap;
use std::sync::Arc;

/// Where a camera, a light or an environment probe's centre looks from: a point to classify,
/// and how far from every surface it must be for its side to count (the near-plane reach of a
/// camera, say).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Viewpoint {
    pub position: Vec3,
    pub clearance: f32,
}

struct Surface {
    /// The first instance the surface has triangles of.
    name: String,
    triangles: Vec<[Vec3; 3]>,
    bounds: Aabb,
}

/// The closed opaque surfaces of a scene.
#[derive(Default)]
pub struct Enclosures {
    /// Sorted by name (shared with [`StaticEnclosures`]).
    surfaces: Vec<Arc<Surface>>,
}

/// The welded static part of a scene whose instances `moving` move: its closed opaque surfaces
/// and its welded vertex positions.
pub struct StaticEnclosures {
    moving: Vec<bool>,
    keys: HashMap<[u32; 3], usize>,
    surfaces: Vec<Arc<Surface>>,
}

impl StaticEnclosures {
    /// Welds the instances of `scene` not in `moving` (indices into `Scene::instances`).
    pub fn new(scene: &Scene, moving: &[usize]) -> Self {
        let mut flags = vec![false; scene.instances.len()];
        for &i in moving {
            if let Some(f) = flags.get_mut(i) {
                *f = true;
            }
        }
        let (surfaces, keys) = Enclosures::weld(scene, |i| !flags[i]);
        Self {
            moving: flags,
            keys,
            surfaces,
        }
    }

    /// Whether the instances `moved` are all among the moving ones (the static part is then
    /// still valid).
    pub fn covers(&self, moved: impl IntoIterator<Item = usize>) -> bool {
        moved
            .into_iter()
            .all(|i| self.moving.get(i).copied().unwrap_or(false))
    }
}

/// Ray directions of the parity test: unit, no zero component, not in any axis plane.
const RAYS: [[f32; 3]; 3] = [
    [0.577_215_7, 0.618_034, 0.533_189_4],
    [-0.688_247_2, 0.324_442_8, 0.648_885_6],
    [0.267_261_2, -0.534_522_5, -0.801_783_7],
];

fn weld_key(p: Vec3) -> [u32; 3] {
    // +0.0 and −0.0 are the same point.
    p.to_array().map(|c| (c + 0.0).to_bits())
}

fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// Distance from `p` to the box around `t` (a lower bound of the distance to `t`).
fn distance_to_box(p: Vec3, min: Vec3, max: Vec3) -> f32 {
    (min - p).max(p - max).max(Vec3::ZERO).length()
}

impl Enclosures {
    pub fn new(scene: &Scene) -> Self {
        Self {
            surfaces: Self::weld(scene, |_| true).0,
        }
    }

    /// [`Self::new`] of `scene`, its static part taken from `statics` (made for the same
    /// scene's instances, none of the static ones moved since): only the moving instances are
    /// welded, unless one of their vertices meets a static one.
    pub fn with_static(statics: &StaticEnclosures, scene: &Scene) -> Self {
        let (moving, keys) = Self::weld(scene, |i| statics.moving.get(i) == Some(&true));
        if keys.keys().any(|k| statics.keys.contains_key(k)) {
            return Self::new(scene);
        }
        let mut surfaces: Vec<Arc<Surface>> =
            statics.surfaces.iter().cloned().chain(moving).collect();
        surfaces.sort_by(|a, b| a.name.cmp(&b.name));
        Self { surfaces }
    }

    /// The closed opaque surfaces of the instances `include` selects, sorted by name, and
    /// their welded vertices.
    fn weld(
        scene: &Scene,
        include: impl Fn(usize) -> bool,
    ) -> (Vec<Arc<Surface>>, HashMap<[u32; 3], usize>) {
        let fallback = Material::default();
        let mut keys: HashMap<[u32; 3], usize> = HashMap::new();
        let mut positions: Vec<Vec3> = Vec::new();
        // Welded triangles: vertex ids, world corners, instance, opaque.
        let mut triangles: Vec<([usize; 3], [Vec3; 3], usize, bool)> = Vec::new();
        for (i, inst) in scene.instances.iter().enumerate() {
            if !include(i) {
                continue;
            }
            let mesh = &scene.meshes[inst.mesh];
            let material = scene.materials.get(mesh.material).unwrap_or(&fallback);
            let opaque = !MaterialLobes::of(material).refraction;
            for t in &mesh.triangles {
                let p = t.map(|v| inst.transform.transform_point3(mesh.positions[v as usize]));
                let ids = p.map(|q| {
                    *keys.entry(weld_key(q)).or_insert_with(|| {
                        positions.push(q);
                        positions.len() - 1
                    })
                });
                if ids[0] != ids[1] && ids[1] != ids[2] && ids[0] != ids[2] {
                    triangles.push((ids, p, i, opaque));
                }
            }
        }
        let mut parent: Vec<usize> = (0..positions.len()).collect();
        let mut edges: HashMap<(usize, usize), u32> = HashMap::new();
        for (ids, ..) in &triangles {
            for k in 0..3 {
                let (a, b) = (ids[k], ids[(k + 1) % 3]);
                *edges.entry((a.min(b), a.max(b))).or_default() += 1;
                let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
                parent[ra] = rb;
            }
        }
        // Per component (keyed by its root vertex): closed and opaque so far, and its surface.
        let mut components: HashMap<usize, (bool, Surface)> = HashMap::new();
        for (ids, p, instance, opaque) in &triangles {
            let root = find(&mut parent, ids[0]);
            let closed = (0..3).all(|k| {
                let (a, b) = (ids[k], ids[(k + 1) % 3]);
                edges[&(a.min(b), a.max(b))] % 2 == 0
            });
            let (ok, surface) = components.entry(root).or_insert_with(|| {
                (
                    true,
                    Surface {
                        name: scene.instances[*instance].name.clone(),
                        triangles: Vec::new(),
                        bounds: Aabb::EMPTY,
                    },
                )
            });
            *ok &= closed && *opaque;
            for q in p {
                surface.bounds.grow(*q);
            }
            surface.triangles.push(*p);
        }
        let mut surfaces: Vec<Arc<Surface>> = components
            .into_values()
            .filter(|(ok, _)| *ok)
            .map(|(_, s)| Arc::new(s))
            .collect();
        surfaces.sort_by(|a, b| a.name.cmp(&b.name));
        (surfaces, keys)
    }

    /// Number of closed opaque surfaces found.
    pub fn len(&self) -> usize {
        self.surfaces.len()
    }

    pub fn is_empty(&self) -> bool {
        self.surfaces.is_empty()
    }

    /// `Some(true)` inside `surface`, `Some(false)` outside, `None` when not provable.
    fn inside(surface: &Surface, viewpoint: &Viewpoint) -> Option<bool> {
        let p = viewpoint.position;
        if !p.is_finite() {
            return None;
        }
        if distance_to_box(p, surface.bounds.min, surface.bounds.max) > viewpoint.clearance {
            return Some(false);
        }
        let near = surface.triangles.iter().any(|t| {
            let min = t[0].min(t[1]).min(t[2]);
            let max = t[0].max(t[1]).max(t[2]);
            distance_to_box(p, min, max) <= viewpoint.clearance
        });
        if near {
            return None;
        }
        let mut answers = Vec::with_capacity(RAYS.len());
        for dir in RAYS {
            let ray = WatertightRay::new(p, Vec3::from_array(dir));
            let mut crossings = 0u32;
            let mut clean = true;
            for t in &surface.triangles {
                if let Some(hit) = ray.intersect(t[0], t[1], t[2], f32::INFINITY) {
                    crossings += 1;
                    clean &= hit.b0 != 0.0 && hit.b1 != 0.0 && hit.b2 != 0.0;
                }
            }
            if clean {
                answers.push(crossings % 2 == 1);
            }
        }
        let agree = answers.windows(2).all(|w| w[0] == w[1]);
        (answers.len() >= 2 && agree).then(|| answers[0])
    }

    /// The name of a closed opaque surface with `a` provably on one side and `b` on the other,
    /// if there is one.
    pub fn separating(&self, a: &Viewpoint, b: &Viewpoint) -> Option<&str> {
        self.surfaces
            .iter()
            .find(|s| match (Self::inside(s, a), Self::inside(s, b)) {
                (Some(x), Some(y)) => x != y,
                _ => false,
            })
            .map(|s| s.name.as_str())
    }
}
