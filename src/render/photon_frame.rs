//! The photon part of an ISPM frame: light G-buffers → bounce map → readback → CPU trace →
//! kernel radii (`photon::density`) → upload → photon volumes (→ upsample at
//! `--subsample N > 1`) → composite; and, for glass and mirrors, the photons' light seen from
//! each environment probe's centre (`environment.rs`). Owns the buffers and passes those steps use; `frame.rs`
//! calls its three steps in order. The first four run for the lights whose photons changed
//! only; the others' are kept (`retrace.rs`).
//!
//! The photon map does not depend on the camera: light G-buffers, bounce map, the CPU trace (its
//! BVH built from the instances moved by −centre in f64) and photon positions are relative to
//! the scene's centre (`BouncePlan::origin`), and the photon volumes
//! add `origin − eye` (f64, rounded once to f32) to each position when they are drawn, so a
//! camera move ([`PhotonFrame::set_view`]) changes push constants, not photons:
//!
//! ```text
//!   world ──(f64: − origin)──► photon map (f32, traced once) ──(+ (origin − eye), f32)──► volumes
//!                                                                 ▲ set_view: the eye, yfov
//! ```
//!
//! **Kernel radii.** Each photon's kernel radius comes from the density of the photons of its
//! class around it (`photon::density`, the k-th nearest neighbour), over the whole photon map:
//! every light's photons, so [`PhotonFrame::trace`] measures it again whenever it runs, kept
//! lights included (their photons' neighbours may have changed). The per-light photons
//! (`retrace::Traced`) keep the tracer's unit normals, and the radii are kept beside them in
//! photon-map order; only the copy written to the staging buffers, and
//! [`PhotonFrame::photon_map`], pack each normal with its radius (`photon::types::pack_normal`).
//! So the kept photons stay exactly what a trace makes (the reuse's bit-for-bit invariant is
//! about them), and the radii cannot go stale inside them.
//!
//! **Files.** This one holds the state ([`PhotonFrame`]), its changes between frames (photon
//! sample, radius scale, lights, instances) and what tests and views read of it; `setup.rs`
//! makes it ([`PhotonFrame::new`]); `emission.rs` records box A (light G-buffers, bounce map)
//! and the bounce map's readback; `host_trace.rs` box C (the CPU trace, kNN radii, staging
//! buffers) and the photon map's upload; `estimate.rs` box D's estimate and composite;
//! `retrace.rs` the per-light reuse; `buffers.rs` the buffers split at a descriptor's reach;
//! `environment.rs` the photons' light on glass and mirrors.

use crate::gpu::{Buffer, Gpu, Image};
use crate::passes::bounce_map::{BounceMapPass, ViewBatch};
use crate::passes::composite::CompositePass;
use crate::passes::denoise::DenoisePass;
use crate::passes::eye_gbuffer::GBuffer;
use crate::passes::light_gbuffer::LightGBufferPass;
use crate::passes::photon_tiles::PhotonTilesPass;
use crate::passes::photon_volumes::PhotonVolumesPass;
use crate::passes::support::SupportPass;
use crate::passes::upsample::UpsamplePass;
use crate::photon::bvh::SceneBvh;
use crate::photon::density::Neighbours;
use crate::photon::kernel::{KernelSettings, FINE_KERNEL_PIXELS};
use crate::photon::trace::TraceSettings;
use crate::photon::types::{pack_normal, BounceMapPhoton, Photon};
use crate::plan::bounce_plan::{BouncePlan, Capacity};
use crate::scene::Scene;
use crate::timing;
use retrace::Traced;
use std::sync::Arc;

mod buffers;
mod emission;
pub mod environment;
mod estimate;
mod host_trace;
mod retrace;
mod setup;

use buffers::{BounceBuffers, PhotonBuffers};

/// A stored photon as the GPU draws it: its normal packed with its kNN radius `r`, `offset`
/// added to its position.
fn drawn(p: &Photon, r: f32, offset: glam::Vec3) -> Photon {
    Photon {
        position: p.position + offset,
        normal: pack_normal(p.normal, r),
        ..*p
    }
}

pub struct PhotonFrame {
    gpu: Arc<Gpu>,
    scene: Scene,
    bvh: SceneBvh,
    plan: BouncePlan,
    /// The light views, texels and light-G-buffer layer size the buffers hold.
    capacity: Capacity,
    /// The caustic views' share of each light's photons (`RenderSettings::caustic_share`):
    /// with the effects plan's budget and the scene's bounds, what the plan is made from.
    caustic_share: f32,
    /// `RenderSettings::whole_light_grids`: every texel sends its photon.
    whole_grids: bool,
    bounds: crate::scene::Aabb,
    trace: TraceSettings,
    /// The renderer's `--seed`: photon sample 0's, from which every other sample's seed is
    /// derived ([`Self::set_sample`]).
    base_seed: u32,
    /// The photon sample of the next traced map: its bounce-map seed, CPU path seed and the
    /// texels' jittered points (`bounce_plan::texel_jitter`).
    sample: u32,
    light_gbuffer: GBuffer,
    light_pass: LightGBufferPass,
    views: Buffer,
    /// The bounce map on the GPU, over one or more buffers ([`BounceBuffers`]).
    bounce_map: BounceBuffers,
    /// Its host-visible copy, one buffer (a copy's size is not limited by a descriptor's
    /// reach), record `i` at `i × 32` bytes.
    readback: Buffer,
    bounce_pass: BounceMapPass,
    /// The photon map: staging and device buffers of at most `per_buffer` photons each, and
    /// the photons in each ([`PhotonBuffers`]).
    buffers: PhotonBuffers,
    rebind: bool,
    /// The density estimator: photon volumes or the tiled gather (`--density`).
    estimator: Estimator,
    /// `--subsample N > 1`: the low-resolution targets and the pass that upsamples them.
    subsampled: Option<Subsampled>,
    indirect: Image,
    /// At subsample 1: the global photons' share of the estimate beside `indirect` and the
    /// pass that normalises it by its kernel's support on the surface (`passes/support.rs`).
    support: Option<([Image; 2], SupportPass)>,
    composite: CompositePass,
    /// `--denoise L > 0`: the indirect light's filter and its levels L (`passes/denoise.rs`).
    denoise: Option<(DenoisePass, u32)>,
    /// The last frame's bounce map and photon map per light (positions relative to
    /// `plan.origin`), and the plan they were traced with (`retrace.rs`).
    traced: Traced,
    /// Whether unchanged lights keep their photons (not under `--effects all`).
    reuse_lights: bool,
    /// k per photon class of the kNN radii.
    neighbours: Neighbours,
    /// Each photon's kNN radius (metres), in photon-map order (light after light): packed into
    /// the normals the GPU draws (module docs, "Kernel radii").
    radii: Vec<f32>,
    /// Per light: whether this frame traces its photons again ([`Self::record_emission`]).
    retrace: Vec<bool>,
    /// The views this frame's light G-buffers and bounce map are made for, in batches of
    /// consecutive views (the re-traced lights'); empty: nothing emitted on the GPU.
    batches: Vec<ViewBatch>,
    /// The eye the photon volumes are drawn for ([`Self::set_view`]).
    eye: glam::DVec3,
    /// The kernel's scene-relative clamp, before the view's footprint floor; with `yfov`,
    /// every kernel an estimate draws with ([`Self::kernel_at`]).
    kernel_clamp: KernelSettings,
    /// The vertical field of view of the camera the estimate is drawn for ([`Self::set_view`]).
    yfov: f32,
    /// Height of the image the estimate is made at (the low one when subsampling).
    estimate_height: u32,
    /// The full image size and the subsample factor: with the `view_proj` the frame gives each
    /// estimate, the screen the tiled estimator bins for.
    screen_size: ((u32, u32), u32),
    /// The tiled estimator's lists of the last recorded estimate.
    tile_stats: Option<crate::passes::photon_tiles::TileStats>,
    /// Caustic photons (`photon::density::PhotonClass`) in the last traced photon map.
    caustic_photons: usize,
    /// The photon map as uploaded: light after light, normals packed with the radii
    /// ([`drawn`]). What the tiled estimator bins and [`Self::photon_map`] gives; rebuilt by
    /// every trace (empty until one succeeds), its memory reused.
    packed: Vec<Photon>,
}

/// The density estimator of the frame (`--density`, resolved for the device).
enum Estimator {
    Volumes(Box<PhotonVolumesPass>),
    Tiled(PhotonTilesPass),
}

/// The targets the estimate is made into: `[indirect, global, weight]` at full resolution,
/// `[irradiance, glossy, global, weight]` at `--subsample N > 1`.
fn estimate_targets<'a>(
    indirect: &'a Image,
    support: Option<&'a ([Image; 2], SupportPass)>,
    subsampled: Option<&'a Subsampled>,
) -> Vec<&'a Image> {
    match (subsampled, support) {
        (Some(sub), _) => vec![
            &sub.low[0],
            &sub.low[1],
            &sub.support.0[0],
            &sub.support.0[1],
        ],
        (None, Some((images, _))) => vec![indirect, &images[0], &images[1]],
        (None, None) => unreachable!("the support targets exist at subsample 1"),
    }
}

struct Subsampled {
    /// The fine photons' estimate at full resolution, in a scene that can make caustic
    /// photons (`estimate.rs`'s module docs).
    fine: Option<FinePhotons>,
    low: [Image; 2],
    /// The global photons' share of `low` and the pass that normalises it by its kernel's
    /// support on the surface (`passes/support.rs`).
    support: ([Image; 2], SupportPass),
    upsample: UpsamplePass,
    subsample: u32,
}

/// The fine photons' estimate at full resolution when subsampling (`estimate.rs`'s module
/// docs).
struct FinePhotons {
    /// An estimator of the frame's kind at subsample 1, adding the fine photons to `indirect`.
    estimator: Estimator,
    /// The photon volumes' other two full-resolution targets (the global photons' share and
    /// weight: zero, the fine photons are caustic ones), which their render pass needs beside
    /// `indirect`; the tiled gather touches `indirect` alone.
    support: Option<[Image; 2]>,
}

/// The split between fine and coarse photons at subsample `n` when the full image's kernel is
/// `full`: [`FINE_KERNEL_PIXELS`] low-resolution pixels, per metre of eye distance.
fn fine_split(full: &KernelSettings, n: u32) -> f32 {
    FINE_KERNEL_PIXELS * n as f32 * full.pixel_angle()
}

/// The random seed of photon sample `sample` of a renderer seeded `seed`: `seed` itself for
/// sample 0 (the frame-coherent map), a hash of both for the others.
pub fn sample_seed(seed: u32, sample: u32) -> u32 {
    if sample == 0 {
        seed
    } else {
        crate::photon::rng::hash2(seed, sample)
    }
}

/// The subsample factor a frame uses: at least 1, at most the image's larger side (beyond it
/// the low-resolution image stays 1×1).
/// The frame's buffers and images the photon part reads and writes.
pub struct PhotonTargets<'a> {
    pub frame: &'a Buffer,
    pub gbuffer: &'a GBuffer,
    pub radiance: &'a Image,
    /// The direct pass's `c_L/π` image, which the upsample reads (at `--subsample N > 1`;
    /// `passes/direct.rs`).
    pub lambert: Option<&'a Image>,
}

/// `transform` followed by a move of `-origin`, composed in f64.
fn relative_to(origin: glam::DVec3, transform: glam::Mat4) -> glam::Mat4 {
    let mut m = transform.as_dmat4();
    m.w_axis -= origin.extend(0.0);
    m.as_mat4()
}

impl PhotonFrame {
    /// Makes the next traced photon map photon sample `sample`: an independent set of photons
    /// (every light traced again, with seeds derived from `--seed` and `sample`, and its
    /// texels' photons through other jittered points) for progressive accumulation. Sample 0
    /// is the renderer's frame-coherent map, which moving lights keep using.
    pub fn set_sample(&mut self, sample: u32) {
        if sample == self.sample {
            return;
        }
        self.sample = sample;
        self.trace.seed = sample_seed(self.base_seed, sample);
        self.traced.invalidate();
    }

    /// Scales every photon's kernel radius by `scale` from the next estimate on: the
    /// progressive schedule of an accumulation (`photon::progressive`), applied to the clamped
    /// radius and not to the footprint floor (`photon::kernel`).
    pub fn set_radius_scale(&mut self, scale: f32) {
        self.kernel_clamp.scale = scale;
    }

    /// The photon sample of the last traced map ([`Self::set_sample`]).
    pub fn sample(&self) -> u32 {
        self.sample
    }

    /// Moves the lights (same lights, new transforms or powers; `budget`: the effects plan's
    /// photons for them, `EffectsPlan::photon_budget`): the next frame's bounce map starts from
    /// them. Caustic views are
    /// subdivided less if they would not fit the buffers (`BouncePlan::within`); fails if the
    /// new lights' main views need more light views, texels or a larger light G-buffer than the
    /// renderer was created with.
    pub fn set_lights(
        &mut self,
        lights: &[crate::scene::Light],
        budget: &[Option<usize>],
    ) -> anyhow::Result<()> {
        // In place (the scene's meshes are not copied), and back if the plan does not fit.
        let before = std::mem::replace(&mut self.scene.lights, lights.to_vec());
        let (origin, bounds) = (self.plan.origin, &self.bounds);
        let plan = timing::timed("bounce plan", || {
            BouncePlan::within(
                &self.scene,
                budget,
                origin,
                bounds,
                self.caustic_share,
                &self.capacity,
            )
        });
        match plan {
            Ok(plan) => {
                self.plan = if self.whole_grids {
                    plan.whole_grids()
                } else {
                    plan
                };
                Ok(())
            }
            Err(e) => {
                self.scene.lights = before;
                Err(e)
            }
        }
    }

    /// Moves instances (`moved`: index and new world-from-object transform) for the next
    /// frame's trace, and plans the light views again for `lights` and the effects plan's photon
    /// budget `budget` (caustic windows follow moving mirrors and glass), as
    /// [`Self::set_lights`] does. The BVH moves the instances by transform; only an instance
    /// that was static makes it rebuild its static part (once). On error nothing has moved.
    pub fn move_instances(
        &mut self,
        moved: &[(usize, glam::Mat4)],
        lights: &[crate::scene::Light],
        budget: &[Option<usize>],
    ) -> anyhow::Result<()> {
        let before: Vec<glam::Mat4> = moved
            .iter()
            .map(|&(i, _)| self.scene.instances[i].transform)
            .collect();
        for &(i, m) in moved {
            self.scene.instances[i].transform = m;
        }
        if let Err(e) = self.set_lights(lights, budget) {
            for (&(i, _), m) in moved.iter().zip(before) {
                self.scene.instances[i].transform = m;
            }
            return Err(e);
        }
        for &(i, m) in moved {
            self.bvh
                .set_instance_transform(i, relative_to(self.plan.origin, m));
        }
        self.bvh.update();
        // Every light's photons depend on the geometry.
        self.traced.invalidate();
        Ok(())
    }

    /// Whether [`Self::trace`] left photons to upload and draw.
    pub fn has_photons(&self) -> bool {
        self.count() > 0
    }

    /// Photons in the photon map this frame.
    fn count(&self) -> u32 {
        self.buffers.counts.iter().sum()
    }

    /// The CPU tracer's BVH.
    pub fn bvh(&self) -> &SceneBvh {
        &self.bvh
    }

    /// The light views the bounce map is made of.
    pub fn plan(&self) -> &BouncePlan {
        &self.plan
    }

    /// The last frame's bounce map, one record per light-G-buffer texel.
    pub fn bounce_map(&self) -> &[BounceMapPhoton] {
        self.traced.bounce_map()
    }

    /// The last traced photon map as the photon volumes draw it now: positions relative to the
    /// eye, made the way the vertex shader makes them (the stored position plus
    /// `origin − eye`, in f32), and normals packed with the photons' kNN radii, as uploaded
    /// (`photon::types::pack_normal`; [`Self::kernel`] turns a radius into the kernel's).
    pub fn photon_map(&self) -> Vec<Photon> {
        let offset = self.eye_offset();
        (self.packed.iter())
            .map(|p| Photon {
                position: p.position + offset,
                ..*p
            })
            .collect()
    }

    /// Light `light`'s share of the last photon map: its photons (positions relative to the
    /// plan's origin, as stored), and the bounce-map photons they were traced from.
    pub fn light_photons(&self, light: usize) -> (&[Photon], usize) {
        self.traced
            .lights()
            .get(light)
            .map_or((&[], 0), |l| (l.photons.as_slice(), l.starts))
    }
}
