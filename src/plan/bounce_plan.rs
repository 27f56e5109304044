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

mod caster;
mod coverage;
mod starts;
mod texels;
mod views;

pub use caster::{casters, Caster};
pub use texels::{light_seed, texel_jitter, texel_kept};

use crate::layout::shared_constants::BOUNCE_VIEW_CAUSTIC;
use crate::layout::{BounceView, FrameUniforms};
use crate::photon::emit::photon_budget;
use crate::scene::{Aabb, Scene};
use glam::{DMat4, DVec3};
use std::ops::Range;

/// Largest light-G-buffer resolution per view (texels per side).
pub const MAX_RESOLUTION: u32 = 2048;

use crate::config::settings::CAUSTIC_SHARE;

/// The largest subdivision k of a caustic view (k² caustic texels per main texel).
pub const MAX_CAUSTIC_SUBDIVISION: u32 = 16;

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

/// The lights a plan is made for.
#[derive(Clone, Copy)]
struct LightsToPlan<'a> {
    scene: &'a Scene,
    /// Per light, its photons (`None`: no views; see [`BouncePlan::with_budget`]).
    budget: &'a [Option<usize>],
    origin: DVec3,
    bounds: &'a Aabb,
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

    /// The plan with every texel kept ([`RenderSettings::whole_light_grids`]): its lights emit
    /// their slots, the budget rounded up to whole grids.
    ///
    /// [`RenderSettings::whole_light_grids`]: crate::config::settings::RenderSettings::whole_light_grids
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
}

#[cfg(test)]
mod tests;
