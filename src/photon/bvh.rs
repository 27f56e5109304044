//! [`SceneBvh`]: closest-hit and any-hit ray queries against a [`Scene`] (and a closest hit
//! with some instances left out, [`SceneBvh::intersect_skipping`]): obvhs's compressed
//! wide BVH8 (CWBVH, Ylitie et al. 2017) and its traversal, with a conservative SIMD node test
//! of our own and our watertight triangle test ([`super::triangle`]) for every leaf primitive
//! (obvhs's own Möller–Trumbore test is not watertight).
//!
//! # Two levels: static geometry once, moving instances by transform
//!
//! - **Static part**: the world-space triangles of every instance that does not move, in one
//!   CWBVH built once (PLOC + reinsertion, obvhs's `medium_build` preset).
//! - **Moving instances**: one object-space CWBVH per mesh (shared by every moving instance of
//!   that mesh, built once); each moving instance keeps its transform, inverse and world box.
//!   Rays are transformed into instance space (same `t`), so moving an instance costs a matrix
//!   inverse and eight transformed box corners in [`SceneBvh::update`], never a rebuild.
//! - **Top level**: a list of the moving instances' world boxes, tested after the static part
//!   with the ray shortened to the closest hit so far. A list is the right structure for the
//!   handful of animated nodes a glTF scene has; past a few dozen it wants a CWBVH over the
//!   boxes (obvhs's `build_cwbvh` over `Aabb`s), rebuilt in `update`.
//!
//! Refitting one world-space BVH was the alternative; it needs the moved triangles transformed
//! every frame and loses quality as the motion grows, and obvhs refits only its BVH2, whose
//! conversion to CWBVH is a rebuild of the wide tree anyway. Measured on 101 920 triangles
//! (`docs/performance.md`, shared 2-core machine): building the static CWBVH takes ≈ 85 ms;
//! moving an 81 920-triangle instance and calling `update` takes ≈ 0.12 µs; tracing with that
//! instance in its own level is ≈ 14 % slower than with everything static.
//!
//! Instances declared moving at construction ([`SceneBvh::with_moving_instances`]) are cheap to
//! move. Moving an instance that was static is allowed: it joins the moving set and the static
//! part is rebuilt once, at the next [`SceneBvh::update`].
//!
//! # Robustness of traversal
//!
//! obvhs's own node test is not conservative: it clamps a box's entry distance to at least
//! `1e-4` (absolute, which culls near hits in millimetre scenes), caps `1/dir` at
//! `1/f32::EPSILON` (which culls hits of rays with direction components below `1.2e-7`), and
//! its slab test rounds, so a ray through a point where node boxes meet (a vertex on a box
//! corner) can miss every box around it; the `grid_box` test found such leaks. We therefore
//! run obvhs's traversal (`obvhs::traverse!`: its stack, child ordering and leaf decoding) with
//! our own node test, `node::intersect_node`: the same quantized slab test, the eight children
//! as the lanes of one vectorised loop (eight wide with AVX2, see "Speed"), with every slab
//! widened by a bound on its rounding error (as in pbrt-v4's robust box test, Ize 2013), with
//! the near and far planes picked by the ray's direction signs, entry clamped at 0 and
//! `|1/dir|` capped at 2⁴⁰ (a direction component below 2⁻⁴⁰ is treated as ±2⁻⁴⁰, which can
//! cull a hit only farther than 2⁴⁰ times the origin's distance to the box face).
//!
//! A ray spawned from a hit names the triangle it leaves ([`Ray::leaves`], a [`TriangleKey`]
//! the hit record carries), and the traversal skips that leaf without testing it. The
//! offset origin already keeps the ray off its own triangle (`ray.rs`); the skip spares a test
//! that could only reject. The photon tracer's rays that leave a surface (57 % of them on
//! `benches/photon_trace.rs`'s room; those from the light leave none) each made that test: 0.57
//! of the 3.39 triangle tests a ray over all of them.
//!
//! # Speed
//!
//! On x86-64 CPUs with AVX2, BMI, LZCNT and POPCNT (detected at run time, once, by the
//! `multiversion` crate, which needs no unchecked code of ours) the queries run a copy of themselves compiled for
//! those features, FMA left out so that every result rounds as in the portable build, bit for
//! bit: the node test's loop over the eight children becomes 256-bit instructions, bit scans
//! and population counts are single instructions, and the hit
//! record is inlined into the traversal. Triangles are stored transposed (the x, y and z of
//! their three vertices), so that the watertight test translates, shears and computes its edge
//! functions for the three vertices at once. `docs/performance.md` ("CPU photon tracing") has
//! the profile and the measurements.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use glam::{Mat3, Mat4, UVec2, Vec2, Vec3, Vec3A};
use multiversion::multiversion;
use obvhs::BvhBuildParams;
use obvhs::{cwbvh::builder::build_cwbvh_from_tris, cwbvh::CwBvh, triangle::Triangle};

mod node;
#[cfg(feature = "bvh-stats")]
pub mod stats;

use node::{intersect_node, BoxRay};

use super::ray::{gamma, Hit, Ray, TriangleKey};
use super::triangle::{transpose, TriangleHit, WatertightRay};
use crate::scene::{Mesh, Scene};

/// A CWBVH over triangles, with the triangles stored in the BVH's leaf order.
struct Blas {
    bvh: CwBvh,
    /// Triangle vertices, in leaf order, transposed (`triangle::transpose`: the x, y and z
    /// coordinates of the three vertices), as the watertight test takes them in SIMD lanes.
    rows: Vec<[Vec3A; 3]>,
    /// What the hit record needs of each leaf-order triangle besides its vertices, in one
    /// record: read once per hit, where the mesh's index, normal and uv arrays cost a cache
    /// miss each (they were ~15 % of a photon bounce).
    attributes: Vec<Attributes>,
    /// Wall time of the build.
    build_time: Duration,
}

/// A triangle's identity and vertex attributes (object space: `Mesh::normals`, `Mesh::uvs`).
#[derive(Clone, Copy, Debug)]
struct Attributes {
    /// The instance (unused in a mesh BLAS) and the triangle's index in its mesh.
    instance: u32,
    primitive: u32,
    normals: [Vec3; 3],
    uvs: [Vec2; 3],
}

impl Attributes {
    fn of(mesh: &Mesh, instance: u32, primitive: usize) -> Self {
        let idx = mesh.triangles[primitive].map(|v| v as usize);
        Self {
            instance,
            primitive: primitive as u32,
            normals: idx.map(|v| mesh.normals[v]),
            uvs: idx.map(|v| mesh.uvs[v]),
        }
    }
}

impl Blas {
    fn build(triangles: Vec<[Vec3; 3]>, attributes: Vec<Attributes>) -> Option<Self> {
        if triangles.is_empty() {
            return None;
        }
        let start = Instant::now();
        let input: Vec<Triangle> = triangles
            .iter()
            .map(|&[a, b, c]| Triangle {
                v0: a.into(),
                v1: b.into(),
                v2: c.into(),
            })
            .collect();
        let bvh = build_cwbvh_from_tris(
            &input,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        let order = &bvh.primitive_indices;
        let rows = order
            .iter()
            .map(|&i| transpose(triangles[i as usize]))
            .collect();
        let attributes_in_order = order.iter().map(|&i| attributes[i as usize]).collect();
        Some(Self {
            bvh,
            rows,
            attributes: attributes_in_order,
            build_time: start.elapsed(),
        })
    }

    /// The vertices of leaf-order triangle `leaf`.
    fn vertices(&self, leaf: usize) -> [Vec3; 3] {
        let [x, y, z] = self.rows[leaf];
        [0, 1, 2].map(|v| Vec3::new(x[v], y[v], z[v]))
    }

    /// The watertight test of leaf-order triangle `leaf` (counted with the `bvh-stats`
    /// feature).
    #[inline(always)]
    fn test(&self, ray: &WatertightRay, leaf: usize, t_max: f32) -> Option<TriangleHit> {
        #[cfg(feature = "bvh-stats")]
        stats::count_triangle();
        ray.intersect_transposed(&self.rows[leaf], t_max)
    }

    /// Closest (or, with `any`, first found) hit with `0 < t < t_max`: leaf index and hit.
    /// Leaf `skip_leaf` (the triangle the ray leaves, `usize::MAX` for none) is not tested
    /// ([`TriangleKey`]). With `skip`, triangles of the instances it marks (`skip[instance]`,
    /// the static part's `Attributes::instance`) are not hit; a mesh BLAS takes `None` (its
    /// `instance` is `u32::MAX`). The skip reads each candidate triangle's `Attributes`, not
    /// only the hit's: cheap for the probes' few thousand rays, not free for a tracer's
    /// millions.
    #[inline(always)]
    fn trace(
        &self,
        origin: Vec3,
        dir: Vec3,
        t_max: f32,
        any: bool,
        skip_leaf: usize,
        skip: Option<&[bool]>,
    ) -> Option<(usize, TriangleHit)> {
        let watertight = WatertightRay::new(origin, dir);
        let mut box_ray = BoxRay::new(origin, dir, t_max);
        let mut best: Option<(usize, TriangleHit)> = None;
        let mut closest = t_max;
        let mut state = self.bvh.new_traversal(Vec3A::from(dir));
        let mut node;
        'traversal: {
            obvhs::traverse!(
                self.bvh,
                node,
                state,
                {
                    #[cfg(feature = "bvh-stats")]
                    stats::count_node();
                    intersect_node(node, &box_ray, state.oct_inv4)
                },
                {
                    let i = state.primitive_id as usize;
                    if i == skip_leaf {
                        // The triangle the ray leaves: behind its origin (`TriangleKey`).
                    } else if skip.is_some_and(|s| s[self.attributes[i].instance as usize]) {
                        // Not there for this ray (`SceneBvh::intersect_skipping`).
                    } else if let Some(hit) = self.test(&watertight, i, closest) {
                        best = Some((i, hit));
                        if any {
                            break 'traversal;
                        }
                        closest = hit.t;
                        box_ray.set_t_max(closest);
                    }
                }
            );
        }
        best
    }
}

/// [`SceneBvh::intersect`], compiled once for any x86-64 and once more for x86-64-v3 without
/// FMA (AVX2, BMI, LZCNT, POPCNT; `multiversion` picks the copy by the CPU, detected once), so
/// that the node test's four-wide halves become one eight-wide instruction stream and the
/// traversal's bit scans and population counts single instructions, while every floating-point
/// operation rounds as in the portable copy (no FMA contraction).
#[multiversion(targets("x86_64+avx2+bmi1+bmi2+lzcnt+popcnt"))]
fn intersect_fastest(bvh: &SceneBvh, ray: &Ray) -> Option<Hit> {
    bvh.intersect_portable(ray, None)
}

/// [`SceneBvh::intersect_skipping`], compiled as [`intersect_fastest`] is.
#[multiversion(targets("x86_64+avx2+bmi1+bmi2+lzcnt+popcnt"))]
fn intersect_skipping_fastest(bvh: &SceneBvh, ray: &Ray, skip: &[bool]) -> Option<Hit> {
    bvh.intersect_portable(ray, Some(skip))
}

/// [`SceneBvh::occluded`], compiled as [`intersect_fastest`] is.
#[multiversion(targets("x86_64+avx2+bmi1+bmi2+lzcnt+popcnt"))]
fn occluded_fastest(bvh: &SceneBvh, ray: &Ray) -> bool {
    bvh.occluded_portable(ray)
}

/// An instance's placement and what is derived from it.
#[derive(Clone, Debug)]
struct Placement {
    /// [`TriangleKey::part`] of a moving instance's hits at this placement ([`fresh_part`]).
    part: u64,
    transform: Mat4,
    inverse: Mat4,
    normal_matrix: Mat3,
    /// World box of a moving instance (padded), `None` for static ones.
    world_box: Option<(Vec3, Vec3)>,
    moving: bool,
    /// Negative determinant: glTF makes the clockwise face the front one.
    mirrored: bool,
}

impl Placement {
    fn new(transform: Mat4, moving: bool) -> Self {
        Self {
            part: fresh_part(),
            transform,
            inverse: transform.inverse(),
            normal_matrix: Mat3::from_mat4(transform).inverse().transpose(),
            world_box: None,
            moving,
            mirrored: transform.determinant() < 0.0,
        }
    }
}

/// Ray queries against a scene's triangles; see the module docs.
pub struct SceneBvh {
    meshes: Vec<Mesh>,
    instances: Vec<Instance>,
    /// Index of each instance's first triangle in `Scene::world_triangles` order.
    first_triangle: Vec<u32>,
    static_part: Option<Blas>,
    /// Object-space BVH per mesh, built for meshes that have a moving instance.
    mesh_bvhs: Vec<Option<Blas>>,
    /// Moving instances, in instance order.
    moving: Vec<usize>,
    static_dirty: bool,
    /// Builds of the static part so far (1 after construction; more only when an instance
    /// left it).
    static_builds: u32,
    /// [`TriangleKey::part`] of the static part's hits, new at each build ([`fresh_part`]).
    static_key_part: u64,
    triangle_count: usize,
}

#[derive(Clone, Debug)]
struct Instance {
    mesh: usize,
    placement: Placement,
    pending: Option<Mat4>,
}

impl SceneBvh {
    /// Every instance static: one world-space BVH.
    pub fn new(scene: &Scene) -> Self {
        Self::with_moving_instances(scene, &[])
    }

    /// Instances listed in `moving` get an object-space BVH of their mesh and can be moved
    /// cheaply with [`Self::set_instance_transform`] + [`Self::update`].
    pub fn with_moving_instances(scene: &Scene, moving: &[usize]) -> Self {
        let mut first_triangle = Vec::with_capacity(scene.instances.len());
        let mut count = 0u32;
        let instances = scene
            .instances
            .iter()
            .enumerate()
            .map(|(i, inst)| {
                first_triangle.push(count);
                count += scene.meshes[inst.mesh].triangles.len() as u32;
                Instance {
                    mesh: inst.mesh,
                    placement: Placement::new(inst.transform, moving.contains(&i)),
                    pending: None,
                }
            })
            .collect();
        let mut bvh = Self {
            meshes: scene.meshes.clone(),
            instances,
            first_triangle,
            static_part: None,
            mesh_bvhs: (0..scene.meshes.len()).map(|_| None).collect(),
            moving: Vec::new(),
            static_dirty: true,
            static_builds: 0,
            static_key_part: fresh_part(),
            triangle_count: count as usize,
        };
        bvh.update();
        bvh
    }

    /// Number of triangles over all instances.
    pub fn triangle_count(&self) -> usize {
        self.triangle_count
    }

    /// Wall time of the last build of the static part (zero when it is empty).
    pub fn static_build_time(&self) -> Duration {
        self.static_part
            .as_ref()
            .map_or(Duration::ZERO, |b| b.build_time)
    }

    /// How many times the static part was built (1 unless an instance left it).
    pub fn static_builds(&self) -> u32 {
        self.static_builds
    }

    /// Sets instance `instance`'s world-from-object transform; takes effect at [`Self::update`].
    pub fn set_instance_transform(&mut self, instance: usize, transform: Mat4) {
        let inst = &mut self.instances[instance];
        inst.pending = Some(transform);
        if !inst.placement.moving {
            inst.placement.moving = true;
            self.static_dirty = true;
        }
    }

    /// Applies pending transforms: moving instances get new world boxes; the static part is
    /// rebuilt only when an instance left it.
    pub fn update(&mut self) {
        for inst in &mut self.instances {
            if let Some(transform) = inst.pending.take() {
                inst.placement = Placement::new(transform, inst.placement.moving);
            }
        }
        if self.static_dirty {
            let mut triangles = Vec::new();
            let mut attributes = Vec::new();
            for (i, inst) in self.instances.iter().enumerate() {
                if inst.placement.moving {
                    continue;
                }
                let mesh = &self.meshes[inst.mesh];
                let m = inst.placement.transform;
                for (p, t) in mesh.triangles.iter().enumerate() {
                    triangles.push(t.map(|v| m.transform_point3(mesh.positions[v as usize])));
                    attributes.push(Attributes::of(mesh, i as u32, p));
                }
            }
            self.static_part = Blas::build(triangles, attributes);
            self.static_dirty = false;
            self.static_builds += 1;
            self.static_key_part = fresh_part();
        }
        self.moving.clear();
        for i in 0..self.instances.len() {
            let inst = &self.instances[i];
            if !inst.placement.moving {
                continue;
            }
            self.moving.push(i);
            let mesh = inst.mesh;
            if self.mesh_bvhs[mesh].is_none() {
                let m = &self.meshes[mesh];
                let triangles = m
                    .triangles
                    .iter()
                    .map(|t| t.map(|v| m.positions[v as usize]));
                let attributes = (0..m.triangles.len()).map(|p| Attributes::of(m, u32::MAX, p));
                self.mesh_bvhs[mesh] = Blas::build(triangles.collect(), attributes.collect());
            }
            let world_box = self.mesh_bvhs[mesh].as_ref().map(|blas| {
                let b = blas.bvh.total_aabb;
                let (lo, hi) = (Vec3::from(b.min), Vec3::from(b.max));
                let m = self.instances[i].placement.transform;
                let (mut min, mut max) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
                for k in 0..8 {
                    let pick = |bit: usize, l: f32, h: f32| if k & bit == 0 { l } else { h };
                    let corner = Vec3::new(
                        pick(1, lo.x, hi.x),
                        pick(2, lo.y, hi.y),
                        pick(4, lo.z, hi.z),
                    );
                    let w = m.transform_point3(corner);
                    min = min.min(w);
                    max = max.max(w);
                }
                let pad = (max - min).max(min.abs().max(max.abs())) * 1e-5;
                (min - pad, max + pad)
            });
            self.instances[i].placement.world_box = world_box;
        }
    }

    /// The closest hit with `0 < t < ray.t_max`.
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        intersect_fastest(self, ray)
    }

    /// The closest hit with `0 < t < ray.t_max` among the instances `skip` does not mark
    /// (`skip[instance]`, one entry per instance): those it marks are treated as absent. What
    /// an environment probe's ray needs, which looks past the glass and mirrors its cube leaves
    /// out (`render/photon_frame/environment.rs`).
    ///
    /// # Panics
    /// When `skip` does not have one entry per instance.
    pub fn intersect_skipping(&self, ray: &Ray, skip: &[bool]) -> Option<Hit> {
        assert!(
            skip.len() == self.instances.len(),
            "intersect_skipping: a skip mask of {} entries for {} instances",
            skip.len(),
            self.instances.len()
        );
        intersect_skipping_fastest(self, ray, skip)
    }

    /// [`Self::intersect`]'s body (and, with `skip`, [`Self::intersect_skipping`]'s), inlined
    /// into each copy [`intersect_fastest`] and [`intersect_skipping_fastest`] compile.
    #[inline(always)]
    fn intersect_portable(&self, ray: &Ray, skip: Option<&[bool]>) -> Option<Hit> {
        let mut closest = ray.t_max;
        // (instance, the BLAS it was hit in, its leaf-order triangle, hit).
        let mut best: Option<(usize, &Blas, usize, TriangleHit)> = None;
        if let Some(blas) = &self.static_part {
            if let Some((leaf, hit)) = blas.trace(
                ray.origin,
                ray.dir,
                closest,
                false,
                self.static_leaf(ray),
                skip,
            ) {
                closest = hit.t;
                best = Some((blas.attributes[leaf].instance as usize, blas, leaf, hit));
            }
        }
        for &i in &self.moving {
            let inst = &self.instances[i];
            let Some(blas) = &self.mesh_bvhs[inst.mesh] else {
                continue;
            };
            if skip.is_some_and(|s| s[i]) || !ray_hits_box(ray, inst.placement.world_box, closest) {
                continue;
            }
            let (origin, dir) = to_instance_space(&inst.placement, ray);
            // A mesh BLAS's `Attributes::instance` is `u32::MAX` (the mask would be indexed
            // past its end): the instance is skipped above instead.
            if let Some((leaf, hit)) = blas.trace(
                origin,
                dir,
                closest,
                false,
                moving_leaf(ray, &inst.placement),
                None,
            ) {
                closest = hit.t;
                best = Some((i, blas, leaf, hit));
            }
        }
        best.map(|(instance, blas, leaf, hit)| self.hit_record(ray, instance, blas, leaf, hit))
    }

    /// True when anything is hit with `0 < t < ray.t_max` (shadow rays).
    pub fn occluded(&self, ray: &Ray) -> bool {
        occluded_fastest(self, ray)
    }

    /// [`Self::occluded`]'s body, inlined into each copy [`occluded_fastest`] compiles.
    #[inline(always)]
    fn occluded_portable(&self, ray: &Ray) -> bool {
        if let Some(blas) = &self.static_part {
            if blas
                .trace(
                    ray.origin,
                    ray.dir,
                    ray.t_max,
                    true,
                    self.static_leaf(ray),
                    None,
                )
                .is_some()
            {
                return true;
            }
        }
        self.moving.iter().any(|&i| {
            let inst = &self.instances[i];
            let Some(blas) = &self.mesh_bvhs[inst.mesh] else {
                return false;
            };
            if !ray_hits_box(ray, inst.placement.world_box, ray.t_max) {
                return false;
            }
            let (origin, dir) = to_instance_space(&inst.placement, ray);
            blas.trace(
                origin,
                dir,
                ray.t_max,
                true,
                moving_leaf(ray, &inst.placement),
                None,
            )
            .is_some()
        })
    }

    /// The static part's leaf that `ray` leaves (`usize::MAX` for none: [`TriangleKey`]).
    #[inline(always)]
    fn static_leaf(&self, ray: &Ray) -> usize {
        if ray.leaves.part == self.static_key_part {
            ray.leaves.leaf as usize
        } else {
            usize::MAX
        }
    }

    /// The world-space triangle `primitive` of `instance`, as [`Self::intersect`] sees it.
    pub fn world_triangle(&self, instance: usize, primitive: usize) -> [Vec3; 3] {
        let inst = &self.instances[instance];
        let mesh = &self.meshes[inst.mesh];
        mesh.triangles[primitive].map(|v| {
            inst.placement
                .transform
                .transform_point3(mesh.positions[v as usize])
        })
    }

    /// The hit record of `hit` on leaf-order triangle `leaf` of `blas`, seen in `instance`.
    #[inline(always)]
    fn hit_record(
        &self,
        ray: &Ray,
        instance: usize,
        blas: &Blas,
        leaf: usize,
        hit: TriangleHit,
    ) -> Hit {
        let Attributes {
            primitive,
            normals,
            uvs,
            ..
        } = blas.attributes[leaf];
        let primitive = primitive as usize;
        let inst = &self.instances[instance];
        let mesh = &self.meshes[inst.mesh];
        // The static part holds the world-space triangle, as `world_triangle` computes it.
        let [p0, p1, p2] = if inst.placement.moving {
            self.world_triangle(instance, primitive)
        } else {
            blas.vertices(leaf)
        };
        let (b0, b1, b2) = (hit.b0, hit.b1, hit.b2);
        let position = b0 * p0 + b1 * p1 + b2 * p2;
        let mut position_error = gamma(7) * ((b0 * p0).abs() + (b1 * p1).abs() + (b2 * p2).abs());
        if inst.placement.moving {
            // The ray was intersected in object space: add the error of transforming the
            // object-space point to the world and a spawned origin back (pbrt-v4 §6.8.5).
            let [o0, o1, o2] = blas.vertices(leaf);
            let object_point = b0 * o0 + b1 * o1 + b2 * o2;
            let m = inst.placement.transform;
            let abs3 = Mat3::from_cols(
                m.x_axis.truncate().abs(),
                m.y_axis.truncate().abs(),
                m.z_axis.truncate().abs(),
            );
            position_error += gamma(12) * (abs3 * object_point.abs() + m.w_axis.truncate().abs())
                + gamma(3) * position.abs();
        }
        let front_winding = if inst.placement.mirrored { -1.0 } else { 1.0 };
        let geometric_normal =
            (front_winding * (p1 - p0).cross(p2 - p0)).normalize_or(-ray.dir.normalize_or(Vec3::Z));
        let shading_normal =
            inst.placement.normal_matrix * (b0 * normals[0] + b1 * normals[1] + b2 * normals[2]);
        let uv: Vec2 = b0 * uvs[0] + b1 * uvs[1] + b2 * uvs[2];
        Hit {
            t: hit.t,
            position,
            position_error,
            triangle: self.first_triangle[instance] + primitive as u32,
            primitive: primitive as u32,
            instance: instance as u32,
            barycentrics: Vec2::new(b1, b2),
            geometric_normal,
            shading_normal: shading_normal.normalize_or(geometric_normal),
            uv,
            material: mesh.material,
            front_face: geometric_normal.dot(ray.dir) < 0.0,
            key: TriangleKey {
                part: if inst.placement.moving {
                    inst.placement.part
                } else {
                    self.static_key_part
                },
                leaf: leaf as u32,
            },
        }
    }
}

/// A number that no build of a static part and no placement of an instance has had before, in
/// any [`SceneBvh`] of the process: what a [`TriangleKey`] names its part of a BVH by, so that a
/// key used on another BVH, on a rebuilt static part or on an instance placed anew since skips
/// nothing. Never 0 ([`TriangleKey::NONE`]). 64 bits, so that it never repeats (a 32-bit count
/// would, after about two weeks of 50 instances animated at 60 frames a second, while the
/// static part's number of the start was still in use).
fn fresh_part() -> u64 {
    static NEXT: AtomicU64 = AtomicU64::new(1);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

/// The leaf of a moving instance at `placement` that `ray` leaves (`usize::MAX` for none:
/// [`TriangleKey`]).
#[inline(always)]
fn moving_leaf(ray: &Ray, placement: &Placement) -> usize {
    if ray.leaves.part == placement.part {
        ray.leaves.leaf as usize
    } else {
        usize::MAX
    }
}

fn to_instance_space(placement: &Placement, ray: &Ray) -> (Vec3, Vec3) {
    (
        placement.inverse.transform_point3(ray.origin),
        placement.inverse.transform_vector3(ray.dir),
    )
}

/// Conservative slab test of the ray segment `(0, t_max)` against a padded world box.
fn ray_hits_box(ray: &Ray, world_box: Option<(Vec3, Vec3)>, t_max: f32) -> bool {
    let Some((min, max)) = world_box else {
        return false;
    };
    let (mut near, mut far) = (0.0f32, t_max);
    for a in 0..3 {
        let (o, d) = (ray.origin[a], ray.dir[a]);
        if d == 0.0 {
            if o < min[a] || o > max[a] {
                return false;
            }
            continue;
        }
        let (t0, t1) = ((min[a] - o) / d, (max[a] - o) / d);
        near = near.max(t0.min(t1));
        far = far.min(t0.max(t1));
    }
    near <= far * (1.0 + 2.0 * gamma(3))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::rng::Rng;
    use crate::photon::sampling::uniform_sphere;

    /// The queries as dispatched (the x86-64-v3 copy on a CPU that has it, as on every
    /// machine this project measures on) give the same hits, bit for bit, as their bodies
    /// compiled for any x86-64, static and moving; `intersect_skipping` with nothing marked is
    /// `intersect`, and with the last instance marked (moving or in the static part) its own
    /// portable body.
    #[test]
    fn dispatched_queries_equal_their_portable_bodies_bit_for_bit() {
        let scene = crate::reference::scenes::cornell(3);
        let last = scene.instances.len() - 1;
        for bvh in [
            SceneBvh::new(&scene),
            SceneBvh::with_moving_instances(&scene, &[last]),
        ] {
            let mut rng = Rng::new(11);
            let mut hits = 0;
            let no_skip = vec![false; scene.instances.len()];
            let mut skip_last = no_skip.clone();
            skip_last[last] = true;
            let mut skipped_hits = 0;
            for i in 0..20_000 {
                let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.4 - 1.2;
                let d = uniform_sphere(rng.next_2());
                let t_max = if i % 4 == 0 {
                    rng.next_f32()
                } else {
                    f32::INFINITY
                };
                let ray = Ray::with_t_max(o, d, t_max);
                // The query as dispatched (the x86-64-v3 copy where the CPU has it) against
                // its body compiled here, for any x86-64.
                let (portable, avx2) = (bvh.intersect_portable(&ray, None), bvh.intersect(&ray));
                let bits = |h: Option<Hit>| {
                    h.map(|h| {
                        (
                            h.t.to_bits(),
                            h.position.to_array().map(f32::to_bits),
                            h.triangle,
                        )
                    })
                };
                assert_eq!(bits(portable), bits(avx2), "{ray:?}");
                assert_eq!(portable, avx2);
                let skipping_none = bvh.intersect_skipping(&ray, &no_skip);
                assert_eq!(bits(skipping_none), bits(avx2), "{ray:?}");
                let skipping = bvh.intersect_skipping(&ray, &skip_last);
                let portable_skipping = bvh.intersect_portable(&ray, Some(&skip_last));
                assert_eq!(bits(skipping), bits(portable_skipping), "{ray:?}");
                assert!(
                    skipping.is_none_or(|h| h.instance as usize != last),
                    "{ray:?}"
                );
                skipped_hits += avx2.is_some_and(|h| h.instance as usize == last) as u32;
                let occluded = (bvh.occluded_portable(&ray), bvh.occluded(&ray));
                assert_eq!(occluded.0, occluded.1, "{ray:?}");
                assert_eq!(occluded.0, portable.is_some(), "{ray:?}");
                hits += portable.is_some() as u32;
            }
            assert!(hits > 10_000, "{hits} hits");
            assert!(
                skipped_hits > 100,
                "{skipped_hits} rays hit the skipped instance"
            );
        }
    }

    /// The bundled `glass-cube`'s cube rests on the floor: its bottom face and the floor are
    /// one plane. Seen from the cube's centre with the glass and mirrors skipped, each of 2000
    /// random rays down through the bottom face meets the floor right there, static or moving;
    /// without the skip the closest hit is the glass's own face or the floor, whichever
    /// rounding favours, and a ray spawned on past the glass starts beyond the floor (the
    /// blocky tops the environment probes showed, `render/photon_frame/environment.rs`).
    #[test]
    fn skipping_the_glass_finds_the_floor_it_stands_on_through_its_bottom_face() {
        let scene = crate::scene::bundled::resolve(Some("glass-cube")).expect("bundled scene");
        let delta = scene.delta_instance_mask();
        let cube = (0..scene.instances.len())
            .find(|&i| scene.meshes[scene.instances[i].mesh].triangles.len() == 12)
            .expect("the 12-triangle cube");
        assert!(delta[cube]);
        let corners: Vec<Vec3> = (scene.meshes[scene.instances[cube].mesh].positions.iter())
            .map(|&p| scene.instances[cube].transform.transform_point3(p))
            .collect();
        let (min, max) = corners
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), &p| {
                (a.min(p), b.max(p))
            });
        assert!(min.y.abs() < 1e-6, "the cube rests on y = 0: {min}");
        let centre = (min + max) / 2.0;
        for bvh in [
            SceneBvh::new(&scene),
            SceneBvh::with_moving_instances(&scene, &[cube]),
        ] {
            let mut rng = Rng::new(5);
            let mut glass_first = 0;
            for _ in 0..2000 {
                // A point on the bottom face, off its edges.
                let (u, v) = (rng.next_f32() * 0.98 + 0.01, rng.next_f32() * 0.98 + 0.01);
                let target = Vec3::new(
                    min.x + u * (max.x - min.x),
                    min.y,
                    min.z + v * (max.z - min.z),
                );
                let ray = Ray::new(centre, (target - centre).normalize());
                let hit = bvh.intersect_skipping(&ray, &delta).expect("the floor");
                assert!(!delta[hit.instance as usize], "{ray:?} hit {hit:?}");
                assert!(hit.position.y.abs() < 1e-5, "{ray:?} hit {hit:?}");
                assert!(hit.position.distance(target) < 1e-4, "{ray:?} hit {hit:?}");
                let closest = bvh.intersect(&ray).expect("the cube or the floor");
                glass_first += delta[closest.instance as usize] as u32;
            }
            // The case is real: without the skip the glass's face is often hit first.
            assert!(
                glass_first > 0,
                "no ray met the glass's face before the floor"
            );
        }
    }

    /// Skipping instances is the same as leaving them out of the scene: along 5000 random rays
    /// through `cornell` with its sphere and one wall skipped, `intersect_skipping` finds the
    /// hit (the same `t`, to the bit, and the same point) that `intersect` finds in the scene
    /// without them, static and with the sphere moving.
    #[test]
    fn skipping_instances_is_leaving_them_out_of_the_scene() {
        let scene = crate::reference::scenes::cornell(3);
        let last = scene.instances.len() - 1;
        let mut skip = vec![false; scene.instances.len()];
        (skip[0], skip[last]) = (true, true);
        let mut without = scene.clone();
        without.instances = (scene.instances.iter().zip(&skip))
            .filter(|(_, &s)| !s)
            .map(|(i, _)| i.clone())
            .collect();
        for (bvh, reduced) in [
            (SceneBvh::new(&scene), SceneBvh::new(&without)),
            (
                SceneBvh::with_moving_instances(&scene, &[last]),
                SceneBvh::new(&without),
            ),
        ] {
            let mut rng = Rng::new(17);
            let mut hits = 0;
            for _ in 0..5000 {
                let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 1.8 - 0.9;
                let ray = Ray::new(o, uniform_sphere(rng.next_2()));
                let skipping = bvh.intersect_skipping(&ray, &skip);
                let left_out = reduced.intersect(&ray);
                assert_eq!(skipping.is_some(), left_out.is_some(), "{ray:?}");
                if let (Some(a), Some(b)) = (skipping, left_out) {
                    assert_eq!(a.t.to_bits(), b.t.to_bits(), "{ray:?}");
                    assert!(a.position.distance(b.position) < 1e-5, "{ray:?}");
                    hits += 1;
                }
            }
            assert!(hits > 3000, "{hits} hits");
        }
    }

    /// A skip mask made for another scene (another instance count) is refused up front.
    #[test]
    #[should_panic(expected = "a skip mask of 2 entries for")]
    fn a_skip_mask_of_the_wrong_length_panics() {
        let scene = crate::reference::scenes::cornell(1);
        assert_ne!(scene.instances.len(), 2);
        SceneBvh::new(&scene).intersect_skipping(&Ray::new(Vec3::ZERO, Vec3::Y), &[false; 2]);
    }
}
