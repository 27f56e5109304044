//! The CPU side of Image Space Photon Mapping: how the photon budget becomes light-G-buffer
//! views (DESIGN.md §2.3), and how the bounce map read back from the GPU becomes the photon map
//! (§2, step 4).
//!
//! ```text
//!   photons N ──► light L gets N_L = N·Φ_L/Φ_total
//!             ──► caustic share s_L ──► main views: res = ⌈√((1 − s_L)·N_L / (views_L·f_L))⌉
//!                                   ──► caustic views: the casters' window, k² texels per texel
//!   bounce map (GPU) ──readback──► texel ray + depth → hit point ──► trace_photons ──► photon map
//! ```
//!
//! **Exact power.** A perspective texel carries I · Ω_texel · falloff, with Ω_texel the texel's
//! area on the plane at unit distance foreshortened by (1 + x² + y²)^(-3/2). That is exact to
//! second order; the per-light factor [`BouncePlan`] folds into the intensity makes the sum
//! over all of a light's main texels equal its exact flux (4πI for a point light, 2πI·∫falloff
//! for a spot, E·area of the orthographic window for a directional light), so the photons a
//! light emits always carry exactly its power, whatever the resolution ("rescaled for the
//! rounding").
//!
//! **Spot cones.** A spot light's view is the square around its cone, so a fraction f_L < 1 of
//! its texels (π/4 and less for the single view) lies inside the cone and carries power; the
//! resolution is raised by 1/√f_L, measured on a probe grid, so that the texels *inside* the cone
//! match the light's budget.
//!
//! # Caustic views (Jensen's projection maps, in image space)
//!
//! Photons matter most where they hit a delta material (mirror, glass: `Material::has_delta_lobe`)
//! first: those become caustics, which the smallest kernels resolve, while a photon that hits a
//! diffuse surface first adds to smooth indirect light (or leaves the scene). A view fitted to the
//! whole scene spends few texels on small casters (1.8 % of the sun's view on `caustic-ring`), so
//! each light whose views see delta instances gets, per main view that sees them, a **caustic
//! view**: the rectangle of that view's texels holding the casters' projection, subdivided
//! k × k. It shares the parent view's eye, projection and near and far planes (its
//! matrix is the parent's followed by a 2D scale and offset in clip space), so its texels tile
//! the parent's texels exactly:
//!
//! * a caustic-view texel whose own first hit is a delta material carries 1/k² of its parent
//!   texel's power (the parent's solid angle and falloff, or its area);
//! * a main-view texel (role `BOUNCE_VIEW_PARENT`) whose first hit is a delta material carries
//!   nothing: its k² caustic texels carry all of its power, 1/k² each, including those whose own
//!   first hit is not a delta material (role `BOUNCE_VIEW_CAUSTIC`);
//! * any other main-view texel carries the fraction of its power that its caustic texels do not:
//!   `1 − c`, `c` the fraction of them whose first hit is a delta material (it counts them).
//!
//! So every direction from the light is counted exactly once and each parent texel's power is
//! split exactly: the bounce map still sums to the light's flux (tests/ispm.rs measures
//! 10⁻⁹–10⁻⁷ relative). And the split is unbiased: the power that reaches the casters is
//! measured at the caustic resolution in every parent texel, whatever its centre hit.
//! (Simpler rules fail one way or the other. A caustic texel that kept power only for its own
//! delta hit, with the parent zeroed only for its own, counts a texel on the casters' silhouette
//! twice or not at all wherever the two rasterisations disagree: the flux is off by the order of
//! the perimeter times a texel. One that kept power only inside a parent with a delta hit, the
//! parent keeping all of its power otherwise, is exact but gives the casters c² instead of c of
//! each silhouette texel: the ring's reflected power came out 5.5 % low on `caustic-ring`. And
//! giving each caustic texel its own midpoint solid angle and falloff breaks the sum at second
//! order in the texel size: 4·10⁻⁵ of a narrow spot's flux at 30k photons.)

//! **Budget.** A light's caustic views get the share `s` of its photons ([`CAUSTIC_SHARE`] = ½
//! unless the caller, `--caustic-share`, says otherwise), its main views the rest: the main
//! resolution follows from `(1 − s)·N_L`, and the subdivision is `k = round(√(s·N_L / W))` for
//! caster windows of `W` main texels, at most [`MAX_CAUSTIC_SUBDIVISION`] and [`MAX_RESOLUTION`]
//! per side. If the windows cover the fraction `a` of the main texels, the casters are sampled
//! `k² ≈ s/((1 − s)·a)` times as densely as the rest of the scene: 1/a at s = ½, 49× (k = 7) for
//! the ring of `caustic-ring` (a = 1.8 %), for half of the light's photons taken from the surfaces
//! that only receive diffuse light. Where `k` rounds below 2 (casters covering more than ≈ 45 %
//! of the view at s = ½) the main views already sample them nearly as densely: the light keeps
//! one set of views with its whole budget. `s = 0` turns caustic views off.
//!
//! Whole square grids would emit more than the budget (a spot's cone fills π/4 of its view at
//! most, the texels are whole): the plan counts the texels that send a photon, its *slots*
//! (inside the cone; a window's parent texel as its k × k caustic texels), grows the main views
//! until the slots hold the budget `N_L`, and each texel then sends its photon with probability
//! `N_L / slots`, carrying `slots / N_L` times its texel's power ([`texel_kept`]: a hash of the
//! texel rotated per frame, so every texel takes its turn over an accumulation). A light thus
//! emits `N_L` photons per frame to within the binomial spread (±0.3 % at 10 000). In a caustic
//! window the slots depend on what the texels see (above: a parent texel off the casters sends
//! one photon for its own part, not k²), so the plan predicts which texels the casters cover by
//! rasterising them on the CPU (`coverage.rs`). The stats count the photons the bounce map
//! really sent (`FrameStats::emitted_photons`).

use crate::layout::{
    BounceView, FrameUniforms, LIGHT_AREA_SAMPLE, LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT,
};
use crate::lighting::LightSetup;
use crate::photon::bvh::SceneBvh;
use crate::photon::emit::{light_falloff, photon_budget, spot_falloff_integral};
use crate::photon::rng::hash2;
use crate::photon::trace::PhotonState;
use crate::photon::types::BounceMapPhoton;
use crate::scene::{Aabb, LightKind, Scene};
use crate::shared_constants::{
    BOUNCE_VIEW_CAUSTIC, BOUNCE_VIEW_PARENT, BOUNCE_VIEW_WHOLE, JITTER_R2_X, JITTER_R2_Y,
    JITTER_STREAM_X, JITTER_STREAM_Y, KEEP_R1, KEEP_STREAM, LIGHT_VIEW_FAR_Z, LIGHT_VIEW_NEAR_Z,
};
use glam::{DMat4, DVec2, DVec3, DVec4, UVec4, Vec4};
use rayon::prelude::*;
use std::ops::Range;

mod coverage;

/// Largest light-G-buffer resolution per view (texels per side).
pub const MAX_RESOLUTION: u32 = 2048;

pub use crate::settings::CAUSTIC_SHARE;

/// The largest subdivision k of a caustic view (k² caustic texels per main texel).
pub const MAX_CAUSTIC_SUBDIVISION: u32 = 16;

/// Texels per side of the probe grid that measures the fraction of a light's texels inside its
/// cone.
const PROBE: u32 = 64;

/// Salt of a light's bounce-map seed ([`light_seed`]).
const LIGHT_SEED_STREAM: u32 = 0x6c1e_5eed;
/// `BounceView.kind.w` of a caustic view: this plus its parent's (the parent's own is its index
/// among the light's main views).
const CAUSTIC_ORDINAL: u32 = 16;
/// Salt of a bounce-map photon's CPU path key (its generator must not repeat the texel's).
const CPU_PATH_STREAM: u32 = 0x0c90_7ace;

/// The light views of one frame's photon emission: each light's main views, then its caustic
/// views, light after light.
#[derive(Clone, Debug, Default)]
pub struct BouncePlan {
    pub views: Vec<BounceView>,
    /// Origin-relative world → light clip, per view.
    pub view_matrices: Vec<DMat4>,
    /// The light G-buffer raster's uniforms, per view.
    pub uniforms: Vec<FrameUniforms>,
    /// Texels (width, height) of each view ((0, 0) for lights that get no photons).
    pub extents: Vec<(u32, u32)>,
    /// The index in `scene.lights` of each view's light.
    pub view_lights: Vec<usize>,
    /// The largest width and the largest height of any view: the light G-buffer's layer size.
    pub max_extent: (u32, u32),
    /// Bounce-map records in all (Σ width·height).
    pub texels: usize,
    /// Texels of the caustic views among them.
    pub caustic_texels: usize,
    /// The texels that send a photon when kept: inside their light's cone, in a caustic window
    /// as predicted from the casters' coverage (module docs, "Budget"). At least the budget,
    /// unless a light reached [`MAX_RESOLUTION`].
    pub slots: usize,
    /// The photons the plan emits per frame on average: each light's budget, or its slots
    /// where they fall short. Each slot is kept with probability budget/slots (`BounceView`
    /// `params.y`, `texel_kept`), and a kept photon carries slots/budget times its texel's power.
    pub photons: usize,
    /// The point the matrices, the light views' uniforms and the bounce map's hit points are
    /// relative to (computed in f64). `PhotonFrame` passes the scene's centre, not the camera:
    /// the photon map is then the same whatever the camera, so moving the camera never
    /// re-traces it (docs/overview.md, "The camera").
    pub origin: DVec3,
    /// The lights (indices in `scene.lights`) whose budget asked for main views larger than
    /// [`MAX_RESOLUTION`]² texels: they emit fewer photons than their budget.
    pub lights_at_max_resolution: Vec<usize>,
    /// What the plan's lights may need when they move: see [`BouncePlan::capacity`].
    reserve: Capacity,
}

/// The most light views, bounce-map texels and light-G-buffer layer size (width, height) a
/// renderer's buffers hold.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Capacity {
    pub views: usize,
    pub texels: usize,
    pub extent: (u32, u32),
}

impl Capacity {
    /// Room for both.
    pub fn max(self, other: Capacity) -> Capacity {
        Capacity {
            views: self.views.max(other.views),
            texels: self.texels.max(other.texels),
            extent: (
                self.extent.0.max(other.extent.0),
                self.extent.1.max(other.extent.1),
            ),
        }
    }

    /// Whether `plan` fits.
    pub fn holds(&self, plan: &BouncePlan) -> bool {
        plan.views.len() <= self.views
            && plan.texels <= self.texels
            && plan.max_extent.0 <= self.extent.0
            && plan.max_extent.1 <= self.extent.1
    }
}

/// Depth of a light view's near and far planes (reversed: `lighting.rs`).
const NEAR: f64 = LIGHT_VIEW_NEAR_Z as f64;
const FAR: f64 = LIGHT_VIEW_FAR_Z as f64;

fn unproject(inverse: &DMat4, ndc: DVec2, z: f64) -> DVec3 {
    let h = *inverse * DVec4::new(ndc.x, ndc.y, z, 1.0);
    h.truncate() / h.w
}

/// NDC of the centre of texel (x, y) of a `width`×`height` view (row 0 at NDC y = −1, as
/// Vulkan).
fn texel_ndc(x: u32, y: u32, width: u32, height: u32) -> DVec2 {
    DVec2::new(
        (f64::from(x) + 0.5) / f64::from(width) * 2.0 - 1.0,
        (f64::from(y) + 0.5) / f64::from(height) * 2.0 - 1.0,
    )
}

/// Where inside texel (`x`, `y`) the photon of sample `sample` passes, in texels from its
/// corner, each in [0, 1): the twin of `texel_jitter` in `bounce_map.comp`. A random offset per
/// texel (two hashes of its `key`, [`BouncePlan::texel_key`]) rotated by point `sample` of the R2
/// sequence (Cranley–Patterson rotation), all in 32-bit fixed point so both sides compute the
/// same bits: within a frame every texel has its own offset, so the photons are stratified and
/// jittered over the view (no lattice in a caustic), and over the frames of an accumulation
/// each texel's offsets are a low-discrepancy sequence (`shared_constants.rs`, `JITTER_*`).
pub fn texel_jitter(key: u32, sample: u32) -> DVec2 {
    let fixed = |stream: u32, step: u32| {
        let bits = hash2(key, stream).wrapping_add(sample.wrapping_mul(step));
        // The top 24 bits, as the GLSL side takes them: exact in f32.
        f64::from(bits >> 8) * (1.0 / 16_777_216.0)
    };
    DVec2::new(
        fixed(JITTER_STREAM_X, JITTER_R2_X),
        fixed(JITTER_STREAM_Y, JITTER_R2_Y),
    )
}

/// Whether the texel whose key is `key` sends its photon in sample `sample` when the view keeps
/// texels with probability `keep`: the twin of `texel_kept` in `bounce_map.comp`, bit for bit (a
/// 24-bit fixed-point number, exact in f32, against `keep` as f32). A probability of 1 keeps
/// every texel.
pub fn texel_kept(key: u32, sample: u32, keep: f32) -> bool {
    let bits = hash2(key, KEEP_STREAM).wrapping_add(sample.wrapping_mul(KEEP_R1));
    ((bits >> 8) as f32) * (1.0 / 16_777_216.0) < keep
}

/// NDC of the point `jitter` (texels from the corner, in [0, 1)) of texel (x, y) of a
/// `width`×`height` view.
fn jittered_ndc(x: u32, y: u32, jitter: DVec2, width: u32, height: u32) -> DVec2 {
    DVec2::new(
        (f64::from(x) + jitter.x) / f64::from(width) * 2.0 - 1.0,
        (f64::from(y) + jitter.y) / f64::from(height) * 2.0 - 1.0,
    )
}

/// An instance whose material has a delta lobe: its world-space vertices and their box.
#[derive(Clone, Debug)]
pub struct Caster {
    pub vertices: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
    pub bounds: Aabb,
}

impl Caster {
    /// Its vertices in the clip space of the view `m` (`origin`-relative world → clip).
    fn clip(&self, m: &DMat4, origin: DVec3) -> Vec<DVec4> {
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
fn caster_rect(m: &DMat4, casters: &[Caster], origin: DVec3) -> Option<(DVec2, DVec2)> {
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

/// The lights a plan is made for.
#[derive(Clone, Copy)]
struct LightsToPlan<'a> {
    scene: &'a Scene,
    /// Per light, its photons (`None`: no views; see [`BouncePlan::with_budget`]).
    budget: &'a [Option<usize>],
    origin: DVec3,
    bounds: &'a Aabb,
}

/// A caustic view's window: texels `[i0, i1) × [j0, j1)` of its parent view.
#[derive(Clone, Copy, Debug)]
struct Window {
    parent: usize,
    i0: u32,
    j0: u32,
    i1: u32,
    j1: u32,
}

impl Window {
    fn texels(&self) -> usize {
        ((self.i1 - self.i0) * (self.j1 - self.j0)) as usize
    }
}

impl BouncePlan {
    /// Plans `photons` photons over every light of `scene`, split by power
    /// (`photon::emit::photon_budget`), relative to `origin`, with the default caustic share: a
    /// plan made without an effects plan (the tests). A frame's plan takes the effects plan's
    /// split as it is ([`BouncePlan::with_budget`]).
    pub fn new(scene: &Scene, origin: DVec3, bounds: &Aabb, photons: usize) -> BouncePlan {
        let budget: Vec<Option<usize>> = photon_budget(scene, photons)
            .into_iter()
            .map(Some)
            .collect();
        Self::with_budget(scene, &budget, origin, bounds, CAUSTIC_SHARE)
    }

    /// Plans light `i` of `scene` to emit `budget[i]` photons, the caustic views taking the
    /// share `share` of them (module docs, "Budget"; 0: no caustic views). The budget is the
    /// effects plan's split of the frame's photons (`plan::EffectsPlan::photon_budget`), taken
    /// as it is, never split again here. A light whose budget is `None` (its photon mask off),
    /// or missing from `budget`, gets no views, no light G-buffer layer and no bounce-map texels.
    pub fn with_budget(
        scene: &Scene,
        budget: &[Option<usize>],
        origin: DVec3,
        bounds: &Aabb,
        share: f32,
    ) -> BouncePlan {
        let lights = LightsToPlan {
            scene,
            budget,
            origin,
            bounds,
        };
        Self::plan(&lights, share, MAX_CAUSTIC_SUBDIVISION)
    }

    /// [`BouncePlan::with_budget`] for buffers of `capacity` (a renderer's, for lights that
    /// moved): if the plan does not fit, its caustic views are subdivided less (k lowered for
    /// every light) until it does, or dropped (their photons given to the main views if those
    /// still fit, else not emitted). Fails if even the main views do not fit.
    pub fn within(
        scene: &Scene,
        budget: &[Option<usize>],
        origin: DVec3,
        bounds: &Aabb,
        share: f32,
        capacity: &Capacity,
    ) -> anyhow::Result<BouncePlan> {
        let lights = LightsToPlan {
            scene,
            budget,
            origin,
            bounds,
        };
        for max_k in (2..=MAX_CAUSTIC_SUBDIVISION).rev() {
            let plan = Self::plan(&lights, share, max_k);
            if capacity.holds(&plan) {
                return Ok(plan);
            }
            if plan.caustic_texels == 0 {
                break;
            }
        }
        let plan = Self::plan(&lights, 0.0, MAX_CAUSTIC_SUBDIVISION);
        if capacity.holds(&plan) {
            return Ok(plan);
        }
        let plan = Self::plan(&lights, share, 0);
        anyhow::ensure!(
            capacity.holds(&plan),
            "the lights need {} light views of up to {}×{} texels ({} in all), more than the {} \
             views of {}×{} ({} texels) this renderer has",
            plan.views.len(),
            plan.max_extent.0,
            plan.max_extent.1,
            plan.texels,
            capacity.views,
            capacity.extent.0,
            capacity.extent.1,
            capacity.texels
        );
        Ok(plan)
    }

    /// What buffers for this plan need so that its lights can move without losing their caustic
    /// views: every main view of a scene with mirrors or glass may gain one, holding at most
    /// 16/9 of the light's caustic share (k is its density rounded, and at least 2), with 25 %
    /// more width and height than its caustic views have now, and its main views may grow to
    /// the side that holds the light's whole budget (module docs, "Budget").
    pub fn capacity(&self) -> Capacity {
        self.reserve
    }

    fn plan(lights: &LightsToPlan, share: f32, max_k: u32) -> BouncePlan {
        let LightsToPlan {
            scene,
            budget,
            origin,
            bounds,
        } = *lights;
        // Shadow views are the light G-buffer's views; with resolution 1 their texel parameter
        // is the full window: 2·tan(fov/2) (perspective) or 2·radius (orthographic).
        let setup = LightSetup::photon_views(&scene.lights, origin, bounds);
        let share = if share.is_finite() {
            f64::from(share.clamp(0.0, 0.95))
        } else {
            0.0
        };
        let casters = if share > 0.0 {
            casters(scene)
        } else {
            Vec::new()
        };
        let mut plan = BouncePlan {
            origin,
            ..Default::default()
        };
        let lights = scene.lights.iter().zip(&setup.lights).zip(budget);
        for (index, ((light, gpu_light), &n)) in lights.enumerate() {
            let Some(n) = n else {
                continue;
            };
            let first = gpu_light.shadow.y as usize;
            let count = gpu_light.shadow.z as usize;
            let kind = gpu_light.shadow.x;
            let (cos_outer, cos_inner) = (gpu_light.direction.w, gpu_light.intensity.w);
            let axis = gpu_light.direction.truncate().as_dvec3();
            let ortho = kind == LIGHT_DIRECTIONAL;
            // Spots and emitters' area samples light a cone (a hemisphere) of their views.
            let coned = kind == LIGHT_SPOT || kind == LIGHT_AREA_SAMPLE;
            debug_assert!(kind == LIGHT_POINT || coned || ortho);
            let matrices: Vec<DMat4> = (first..first + count)
                .map(|v| setup.view_matrices[v])
                .collect();
            let inverses: Vec<DMat4> = matrices.iter().map(DMat4::inverse).collect();
            // Half the window: tan(fov/2) on the plane at unit distance, or metres (ortho).
            let halves: Vec<f64> = (first..first + count)
                .map(|v| f64::from(setup.views[v].params.x) * 0.5)
                .collect();
            let direction = |v: usize, ndc: DVec2| {
                (unproject(&inverses[v], ndc, FAR) - unproject(&inverses[v], ndc, NEAR)).normalize()
            };
            let in_cone =
                |v: usize, ndc: DVec2| !coned || axis.dot(direction(v, ndc)) > f64::from(cos_outer);
            let rects: Vec<Option<(DVec2, DVec2)>> = matrices
                .iter()
                .map(|m| {
                    if n > 0 && !casters.is_empty() {
                        caster_rect(m, &casters, origin)
                    } else {
                        None
                    }
                })
                .collect();
            // The probe: the fraction of the main texels inside the cone.
            let mut inside = 0usize;
            if coned {
                for v in 0..count {
                    for y in 0..PROBE {
                        for x in 0..PROBE {
                            inside += usize::from(in_cone(v, texel_ndc(x, y, PROBE, PROBE)));
                        }
                    }
                }
            } else {
                inside = count * (PROBE * PROBE) as usize;
            }
            let probes = (count as u32 * PROBE * PROBE).max(1) as f64;
            let useful = (inside.max(1) as f64 / probes).min(1.0);
            // The main views' side for the share `s` of the budget spent elsewhere, before the
            // cap at MAX_RESOLUTION.
            let main_side = |s: f64| {
                let texels = (1.0 - s) * n as f64 / (useful * count.max(1) as f64);
                texels.sqrt().ceil()
            };
            let main_res = |s: f64| {
                if n == 0 || count == 0 {
                    0
                } else {
                    (main_side(s) as u32).clamp(1, MAX_RESOLUTION)
                }
            };
            let wanted = if rects.iter().any(Option::is_some) {
                share
            } else {
                0.0
            };
            // Each rectangle as whole texels of its view at `res`; windows holding no texel
            // inside the cone are dropped (the casters are outside the light's reach).
            let windows_at = |res: u32| -> Vec<Window> {
                let mut windows = Vec::new();
                for (v, rect) in rects.iter().enumerate() {
                    let Some((lo, hi)) = rect else { continue };
                    let r = f64::from(res);
                    let to_texel = |ndc: f64| (ndc + 1.0) * 0.5 * r;
                    let w = Window {
                        parent: v,
                        i0: (to_texel(lo.x).floor().max(0.0) as u32).min(res),
                        j0: (to_texel(lo.y).floor().max(0.0) as u32).min(res),
                        i1: (to_texel(hi.x).ceil().max(0.0) as u32).min(res),
                        j1: (to_texel(hi.y).ceil().max(0.0) as u32).min(res),
                    };
                    let reaches = (w.j0..w.j1)
                        .any(|y| (w.i0..w.i1).any(|x| in_cone(v, texel_ndc(x, y, res, res))));
                    if w.i1 > w.i0 && w.j1 > w.j0 && reaches {
                        windows.push(w);
                    }
                }
                windows
            };
            let longest = |windows: &[Window]| {
                windows
                    .iter()
                    .map(|w| (w.i1 - w.i0).max(w.j1 - w.j0))
                    .max()
                    .unwrap_or(1)
            };
            let mut res = main_res(wanted);
            let mut main_share = wanted;
            let mut windows = windows_at(res);
            let window_texels: usize = windows.iter().map(Window::texels).sum();
            let mut k = if window_texels > 0 {
                let k = (wanted * n as f64 / window_texels as f64).sqrt().round() as u32;
                k.clamp(1, max_k.clamp(1, MAX_CAUSTIC_SUBDIVISION))
                    .min(MAX_RESOLUTION / longest(&windows))
            } else {
                0
            };
            if k < 2 && wanted > 0.0 {
                // Casters that fill the light's view: its main views sample them densely
                // enough, and get the whole budget (unless `max_k` = 0 took the caustic views
                // away to fit a renderer's buffers).
                windows.clear();
                if max_k > 0 {
                    res = main_res(0.0);
                    main_share = 0.0;
                }
            }
            // The photons the views send ("Budget" above): a main texel inside the cone sends
            // one; under a window, a parent texel on a caster sends its k × k caustic texels'
            // photons, one elsewhere sends its own and those of its caustic texels on a caster
            // (coverage.rs predicts which they are).
            let window_sends = |res: u32, w: &Window, k: u32| -> Vec<usize> {
                let r = f64::from(res);
                let ndc = |t: u32| f64::from(t) / r * 2.0 - 1.0;
                let rect = (
                    DVec2::new(ndc(w.i0), ndc(w.j0)),
                    DVec2::new(ndc(w.i1), ndc(w.j1)),
                );
                let (pw, ph) = (w.i1 - w.i0, w.j1 - w.j0);
                let m = &matrices[w.parent];
                let parents = coverage::covered_texels(m, origin, &casters, rect, (pw, ph));
                let children =
                    coverage::covered_texels(m, origin, &casters, rect, (pw * k, ph * k));
                let kk = (k * k) as usize;
                (0..ph)
                    .flat_map(|y| (0..pw).map(move |x| (x, y)))
                    .map(|(x, y)| {
                        if parents[(y * pw + x) as usize] {
                            return kk;
                        }
                        let hits = (0..k)
                            .flat_map(|j| (0..k).map(move |i| (i, j)))
                            .filter(|&(i, j)| children[((y * k + j) * pw * k + x * k + i) as usize])
                            .count();
                        usize::from(hits < kk) + hits
                    })
                    .collect()
            };
            let slots_at = |res: u32, windows: &[Window], k: u32| -> usize {
                let sends: Vec<Vec<usize>> =
                    windows.iter().map(|w| window_sends(res, w, k)).collect();
                let mut slots = 0usize;
                for v in 0..count {
                    let under = |x: u32, y: u32| {
                        windows.iter().zip(&sends).find_map(|(w, s)| {
                            let inside = w.parent == v
                                && (w.i0..w.i1).contains(&x)
                                && (w.j0..w.j1).contains(&y);
                            inside.then(|| s[((y - w.j0) * (w.i1 - w.i0) + x - w.i0) as usize])
                        })
                    };
                    for y in 0..res {
                        for x in 0..res {
                            if in_cone(v, texel_ndc(x, y, res, res)) {
                                slots += under(x, y).unwrap_or(1);
                            }
                        }
                    }
                }
                slots
            };
            // The probe's estimate rounded up to whole texels may still fall short of the
            // budget (a cone's edge, the windows' whole texels): grow the main views until the
            // views hold it, then keep each texel with probability `keep` so that the light
            // emits its budget, not whole grids (bounce_map.comp, `texel_kept`).
            // A plan fitted to a renderer's buffers (`max_k` lowered by `within`) keeps its
            // main views: they hold what the buffers were sized for, and the light emits fewer
            // photons.
            let mut slots = slots_at(res, &windows, k);
            let mut grown = 0;
            let may_grow = max_k >= MAX_CAUSTIC_SUBDIVISION;
            while may_grow && n > 0 && slots < n && res < MAX_RESOLUTION && grown < 8 {
                let ratio = (n as f64 / slots.max(1) as f64).sqrt();
                res = ((f64::from(res) * ratio).ceil() as u32)
                    .max(res + 1)
                    .min(MAX_RESOLUTION);
                if !windows.is_empty() {
                    windows = windows_at(res);
                    k = k.min(MAX_RESOLUTION / longest(&windows)).max(1);
                }
                slots = slots_at(res, &windows, k);
                grown += 1;
            }
            let keep = if slots > n {
                n as f64 / slots as f64
            } else {
                1.0
            };
            plan.slots += slots;
            plan.photons += slots.min(n);
            let short = slots < n && res >= MAX_RESOLUTION;
            if n > 0 && count > 0 && (short || main_side(main_share) > f64::from(MAX_RESOLUTION)) {
                plan.lights_at_max_resolution.push(index);
            }

            // The main views' per-texel weights, summed for the exact-flux normalisation.
            let side = |v: usize| 2.0 * halves[v] / f64::from(res.max(1));
            let mut sum = 0.0f64;
            if res > 0 {
                for (v, &half) in halves.iter().enumerate() {
                    let side = side(v);
                    if ortho {
                        sum += side * side * f64::from(res * res);
                        continue;
                    }
                    for y in 0..res {
                        for x in 0..res {
                            let ndc = texel_ndc(x, y, res, res);
                            let q = ndc * half;
                            let mut w = side * side / (1.0 + q.length_squared()).powf(1.5);
                            if coned {
                                let cd = axis.dot(direction(v, ndc)) as f32;
                                w *= f64::from(light_falloff(kind, cos_inner, cos_outer, cd));
                            }
                            sum += w;
                        }
                    }
                }
            }
            let exact = match light.kind {
                LightKind::Point => 4.0 * std::f64::consts::PI,
                LightKind::Spot {
                    inner_cone_angle,
                    outer_cone_angle,
                } => {
                    std::f64::consts::TAU
                        * f64::from(spot_falloff_integral(inner_cone_angle, outer_cone_angle))
                }
                LightKind::Directional => sum,
                LightKind::AreaSample => std::f64::consts::PI,
            };
            let scale = if sum > 0.0 { exact / sum } else { 0.0 };
            let light_rel = (light.position.as_dvec3() - origin).as_vec3();
            let template = BounceView {
                inv_view_proj: glam::Mat4::IDENTITY,
                light: light_rel.extend(0.0),
                axis: gpu_light.direction,
                intensity: (light.intensity * scale as f32).extend(cos_inner),
                params: Vec4::ZERO,
                // Temporal case: keyed by the light's name, not its position, so a moving
                // light keeps every texel's random numbers (no flicker as it moves).
                texels: UVec4::new(0, 0, 0, light_seed(&scene.lights, index)),
                kind: UVec4::new(kind, BOUNCE_VIEW_WHOLE, 0, 0),
            };
            let viewer = if ortho {
                (-axis).as_vec3().extend(0.0)
            } else {
                light_rel.extend(1.0)
            };
            // Moved, the main views may grow up to the side that holds the whole budget (their
            // windows' photons falling short: "Budget"), a texel more for the probe.
            let full = (main_res(0.0) + 1).min(MAX_RESOLUTION);
            let first_view = plan.views.len();
            for v in 0..count {
                let child = windows.iter().position(|w| w.parent == v);
                let (role, child) = match child {
                    Some(c) => (BOUNCE_VIEW_PARENT, (first_view + count + c) as u32),
                    None => (BOUNCE_VIEW_WHOLE, 0),
                };
                let corner = -halves[v] as f32;
                let view = BounceView {
                    params: Vec4::new(side(v) as f32, keep as f32, corner, corner),
                    kind: UVec4::new(kind, role, child, v as u32),
                    ..template
                };
                plan.push(matrices[v], view, (res, res), viewer, index);
            }
            for w in &windows {
                let v = w.parent;
                let r = f64::from(res);
                let ndc = |t: u32| f64::from(t) / r * 2.0 - 1.0;
                let (lo, hi) = (
                    DVec2::new(ndc(w.i0), ndc(w.j0)),
                    DVec2::new(ndc(w.i1), ndc(w.j1)),
                );
                // Clip space of the parent → clip space of the window: x' = s·(x − c·w).
                let s = 2.0 / (hi - lo);
                let c = 0.5 * (lo + hi);
                let to_window = DMat4::from_cols(
                    DVec4::new(s.x, 0.0, 0.0, 0.0),
                    DVec4::new(0.0, s.y, 0.0, 0.0),
                    DVec4::Z,
                    DVec4::new(-s.x * c.x, -s.y * c.y, 0.0, 1.0),
                );
                let parent_side = side(v);
                let view = BounceView {
                    params: Vec4::new(
                        (parent_side / f64::from(k)) as f32,
                        keep as f32,
                        (-halves[v] + f64::from(w.i0) * parent_side) as f32,
                        (-halves[v] + f64::from(w.j0) * parent_side) as f32,
                    ),
                    kind: UVec4::new(
                        kind,
                        BOUNCE_VIEW_CAUSTIC,
                        (first_view + v) as u32,
                        CAUSTIC_ORDINAL + v as u32,
                    ),
                    ..template
                };
                let extent = ((w.i1 - w.i0) * k, (w.j1 - w.j0) * k);
                plan.push(to_window * matrices[v], view, extent, viewer, index);
                plan.caustic_texels += (extent.0 * extent.1) as usize;
                // 25 % for the casters' projection, and the main views' growth (below).
                let main_growth = f64::from(full) / f64::from(res.max(1));
                let grown = |t: u32| {
                    ((f64::from(t) * 1.25 * main_growth.max(1.0)).ceil() as u32).min(MAX_RESOLUTION)
                };
                let reserve = &mut plan.reserve.extent;
                *reserve = (
                    reserve.0.max(grown(extent.0)),
                    reserve.1.max(grown(extent.1)),
                );
            }
            if !casters.is_empty() && n > 0 {
                plan.reserve.views += count;
                plan.reserve.texels += (16.0 / 9.0 * share * n as f64).ceil() as usize;
                if full > res {
                    plan.reserve.texels += count * (full * full - res * res) as usize;
                }
                let extent = &mut plan.reserve.extent;
                *extent = (extent.0.max(full), extent.1.max(full));
            }
        }
        plan.reserve.views += plan.views.len() - plan.caustic_views();
        plan.reserve.texels += plan.texels - plan.caustic_texels;
        plan.reserve = plan.reserve.max(Capacity {
            views: plan.views.len(),
            texels: plan.texels,
            extent: plan.max_extent,
        });
        plan
    }

    /// The plan with every texel kept ([`RenderSettings::whole_light_grids`]): its lights emit
    /// their slots, the budget rounded up to whole grids.
    ///
    /// [`RenderSettings::whole_light_grids`]: crate::settings::RenderSettings::whole_light_grids
    pub fn whole_grids(mut self) -> Self {
        for view in &mut self.views {
            view.params.y = 1.0;
        }
        self.photons = self.slots;
        self
    }

    /// How many of the views are caustic views.
    pub fn caustic_views(&self) -> usize {
        self.views
            .iter()
            .filter(|v| v.kind.y == BOUNCE_VIEW_CAUSTIC)
            .count()
    }

    /// Appends a view: its bounce-map range, uniforms and bookkeeping.
    fn push(
        &mut self,
        m: DMat4,
        mut view: BounceView,
        (width, height): (u32, u32),
        viewer: Vec4,
        light: usize,
    ) {
        view.inv_view_proj = m.inverse().as_mat4();
        view.texels.x = width;
        view.texels.y = height;
        view.texels.z = self.texels as u32;
        self.views.push(view);
        self.uniforms.push(FrameUniforms {
            view_proj: m.as_mat4(),
            inv_view_proj: m.inverse().as_mat4(),
            camera_pos: self.origin.as_vec3().extend(1.0),
            counts: UVec4::new(0, 0, width, height),
            params: Vec4::ZERO,
            viewer,
        });
        self.view_matrices.push(m);
        self.extents.push((width, height));
        self.view_lights.push(light);
        self.texels += (width * height) as usize;
        self.max_extent = (self.max_extent.0.max(width), self.max_extent.1.max(height));
    }

    /// The views of light `light` (its index in `scene.lights`): its main views, then its
    /// caustic views, one contiguous range; empty for a light the plan emits no views for
    /// (its budget `None`: its photon mask off). A light whose budget is `Some(0)` still has
    /// views, of extent (0, 0): an empty texel range.
    pub fn light_views(&self, light: usize) -> Range<usize> {
        let Some(first) = self.view_lights.iter().position(|&l| l == light) else {
            return 0..0;
        };
        let count = self.view_lights[first..]
            .iter()
            .take_while(|&&l| l == light)
            .count();
        first..first + count
    }

    /// The bounce-map records of the consecutive views `views` (e.g. [`Self::light_views`]).
    pub fn texel_range(&self, views: Range<usize>) -> Range<usize> {
        let start = self
            .views
            .get(views.start)
            .map_or(0, |v| v.texels.z as usize);
        let count: usize = self.extents[views]
            .iter()
            .map(|&(w, h)| (w * h) as usize)
            .sum();
        start..start + count
    }

    /// Whether light `light` is planned bit for bit as in `other`: the same views at the same
    /// places (view indices: the light G-buffer's layers and the caustic views' parents;
    /// bounce-map offsets: where its kept records lie in the bounce map), with the
    /// same matrices, uniforms, extents, caustic windows and power, from the same origin. With
    /// the geometry, the seed and the bounces unchanged, its bounce-map records and photons
    /// are then the same too (`photon_frame/retrace.rs`).
    pub fn same_light_views(&self, other: &BouncePlan, light: usize) -> bool {
        let (a, b) = (self.light_views(light), other.light_views(light));
        a == b
            && self.origin == other.origin
            && bytemuck::cast_slice::<BounceView, u8>(&self.views[a.clone()])
                == bytemuck::cast_slice::<BounceView, u8>(&other.views[b.clone()])
            && bytemuck::cast_slice::<FrameUniforms, u8>(&self.uniforms[a.clone()])
                == bytemuck::cast_slice::<FrameUniforms, u8>(&other.uniforms[b.clone()])
            && self.view_matrices[a.clone()] == other.view_matrices[b.clone()]
            && self.extents[a] == other.extents[b]
    }

    /// The random-number key of texel (`x`, `y`) of view `v`, the twin of `texel_key` in
    /// `bounce_map.comp`: its light's seed ([`light_seed`]), which of the light's views it is
    /// (`kind.w`) and its texel in that view's grid, a caustic view's counted in its parent's
    /// grid subdivided k × k. Temporal case: none of it changes as a light moves slowly, not
    /// the views before it in the bounce map (their sizes) nor where a caustic window lies, so
    /// each texel keeps its random numbers and its photon moves with the light.
    pub fn texel_key(&self, v: usize, x: u32, y: u32) -> u32 {
        let view = &self.views[v];
        let (mut gx, mut gy) = (x, y);
        if view.kind.y == BOUNCE_VIEW_CAUSTIC {
            // The window's corner in sub-texels of the parent's plane.
            let parent = &self.views[view.kind.z as usize];
            let zw = |p: Vec4| glam::Vec2::new(p.z, p.w);
            let corner = (zw(view.params) - zw(parent.params)) / view.params.x;
            gx = gx.wrapping_add(corner.x.round() as i32 as u32);
            gy = gy.wrapping_add(corner.y.round() as i32 as u32);
        }
        hash2(hash2(hash2(view.texels.w, view.kind.w), gx), gy)
    }

    /// The photons to continue on the CPU: every bounce-map record with power, placed at the
    /// hit point its texel ray (through the texel's jittered point of sample `sample`,
    /// [`texel_jitter`]) and depth describe (in world space), and pushed along its direction by
    /// the hit point's error bound.
    pub fn photon_starts(&self, bounce_map: &[BounceMapPhoton], sample: u32) -> Vec<PhotonState> {
        self.starts(bounce_map, self.origin, 0..self.views.len(), sample, None)
    }

    /// [`Self::photon_starts`] relative to the plan's origin (the renderer's CPU trace, whose
    /// BVH `surface` is built relative to it: `photon_frame.rs`), of the views `views` only
    /// (e.g. one light's, [`Self::light_views`]), in the same order. Each start is snapped onto
    /// the surface its jittered texel ray meets near the bounce map's depth (below).
    pub fn photon_starts_from_origin(
        &self,
        bounce_map: &[BounceMapPhoton],
        views: Range<usize>,
        sample: u32,
        surface: &SceneBvh,
    ) -> Vec<PhotonState> {
        self.starts(bounce_map, DVec3::ZERO, views, sample, Some(surface))
    }

    /// The photon starts of the views `views`, placed in the frame whose origin is `origin` in
    /// the plan's.
    fn starts(
        &self,
        bounce_map: &[BounceMapPhoton],
        origin: DVec3,
        views: Range<usize>,
        sample: u32,
        surface: Option<&SceneBvh>,
    ) -> Vec<PhotonState> {
        // The error of a hit point: 10⁻⁴ of its depth and origin-relative size (the light
        // G-buffer's interpolated position and f32 depth, generously), plus 4ε of its
        // coordinates (their rounding to f32, and the triangles': a few ulps).
        // Scale and position case: no absolute term, so a millimetre scene is not left 0.1 mm
        // off its surfaces, and a scene 10⁵ m from the origin not 10 m (which had every photon
        // leave a 2 m box).
        let error = |relative: DVec3, depth: f32, hit: DVec3| {
            (1e-4 * (relative.abs().max_element() + f64::from(depth))
                + 4.0 * f64::from(f32::EPSILON) * hit.abs().max_element()) as f32
        };
        let mut rays = Vec::new();
        for (v, view) in self
            .views
            .iter()
            .enumerate()
            .take(views.end)
            .skip(views.start)
        {
            let (width, height) = (view.texels.x, view.texels.y);
            if width == 0 || height == 0 {
                continue;
            }
            let inverse = self.view_matrices[v].inverse();
            let offset = view.texels.z as usize;
            for y in 0..height {
                for x in 0..width {
                    let index = offset + (y * width + x) as usize;
                    let Some(p) = bounce_map.get(index) else {
                        continue;
                    };
                    if p.power.max_element().partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
                    {
                        continue;
                    }
                    let texel_key = self.texel_key(v, x, y);
                    let jitter = texel_jitter(texel_key, sample);
                    let ndc = jittered_ndc(x, y, jitter, width, height);
                    let near = unproject(&inverse, ndc, NEAR);
                    let dir = (unproject(&inverse, ndc, FAR) - near).normalize();
                    // The path is keyed by its texel, as the bounce map's own generator is, not
                    // by where it starts.
                    let key = hash2(texel_key, CPU_PATH_STREAM);
                    rays.push((p, near, dir, key));
                }
            }
        }
        // The bounce map placed each photon on the plane of the triangle its texel's centre saw
        // (`bounce_map.comp`); a jittered point past that triangle's edge lies on the plane
        // extended, a hair off the surface (behind it inside a faceted sphere, so the photon
        // would leave). With the BVH, the texel's ray is traced over ±5 % of that depth and the
        // start moved onto the surface it meets there; a ray that meets none (it passes a
        // silhouette) keeps the plane's point.
        let place = |&(p, near, dir, key): &(&BounceMapPhoton, DVec3, DVec3, u32)| {
            let depth = f64::from(p.depth);
            let mut relative = near + dir * depth;
            if let Some(bvh) = surface {
                let from = near + dir * (0.95 * depth);
                let ray = crate::photon::ray::Ray::with_t_max(
                    from.as_vec3(),
                    dir.as_vec3(),
                    (0.1 * depth) as f32,
                );
                if let Some(h) = bvh.intersect(&ray) {
                    relative = h.position.as_dvec3();
                }
            }
            let hit = relative + origin;
            let error = error(relative, p.depth, hit);
            PhotonState::from_bounce_map(p, hit.as_vec3(), error, key)
        };
        rays.par_iter().filter_map(place).collect()
    }
}

/// The bounce-map seed of light `index` of `lights`: a hash of its name and of how many lights
/// before it share the name. Not of its position, so a moving light keeps its texels' random
/// numbers (temporal stability, docs/stability.md); not of its index, so removing another light
/// leaves its photons as they were (`tests/effects_plan.rs`, the enclosed lamp).
pub fn light_seed(lights: &[crate::scene::Light], index: usize) -> u32 {
    let name = &lights[index].name;
    let twins = lights[..index].iter().filter(|l| &l.name == name).count();
    let h = name
        .bytes()
        .fold(LIGHT_SEED_STREAM, |h, b| hash2(h, u32::from(b)));
    hash2(h, twins as u32)
}

#[cfg(test)]
mod tests;
