//! The photon part of an ISPM frame: light G-buffers → bounce map → readback → CPU trace →
//! kernel radii (`photon::density`) → upload → photon volumes (→ upsample at
//! `--subsample N > 1`) → composite; and, for glass and mirrors, the photons' light seen from
//! the environment cube's centre (`environment.rs`). Owns the buffers and passes those steps use; `frame.rs`
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
//! ([`retrace::Traced`]) keep the tracer's unit normals, and the radii are kept beside them in
//! photon-map order; only the copy written to the staging buffers, and
//! [`PhotonFrame::photon_map`], pack each normal with its radius (`photon::types::pack_normal`).
//! So the kept photons stay exactly what a trace makes (the reuse's bit-for-bit invariant is
//! about them), and the radii cannot go stale inside them.

use crate::gpu::{vk, Access, Buffer, Cmd, Gpu, Image, MemoryLocation, QueueRole, ViewKind};
use crate::gpu_scene::GpuScene;
use crate::ispm::{BouncePlan, Capacity};
use crate::pass_id::PassId;
use crate::passes::bounce_map::{BounceMapIo, BounceMapPass, ViewBatch};
use crate::passes::composite::CompositePass;
use crate::passes::denoise::DenoisePass;
use crate::passes::eye_gbuffer::GBuffer;
use crate::passes::light_gbuffer::LightGBufferPass;
use crate::passes::photon_tiles::PhotonTilesPass;
use crate::passes::photon_volumes::{self, PhotonVolumeInputs, PhotonVolumesPass};
use crate::passes::support::SupportPass;
use crate::passes::upsample::{self, UpsampleInputs, UpsamplePass};
use crate::photon::bvh::SceneBvh;
use crate::photon::density::{knn_radii, Neighbours};
use crate::photon::emit::photon_budget;
use crate::photon::kernel::KernelSettings;
use crate::photon::trace::{StoreOn, TraceSettings};
use crate::photon::types::{pack_normal, BounceMapPhoton, Photon};
use crate::plan::{Effects, EffectsPlan};
use crate::scene::Scene;
use crate::settings::{Density, RenderSettings, FRAMES_IN_FLIGHT};
use crate::stats::FrameStats;
use crate::timing;
use anyhow::Context;
use retrace::Traced;
use std::ops::Range;
use std::sync::Arc;

mod buffers;
pub mod environment;
mod estimate;
mod retrace;

use buffers::{photons_per_buffer, storage_buffer_range, BounceBuffers, PhotonBuffers};

/// Poses of an animated scene over one period that the buffers are sized for.
const POSE_SAMPLES: usize = 24;

/// Photons packed at a time for the staging buffers (3 MiB).
const WRITE_CHUNK: usize = 1 << 16;

/// `traced`'s photon map as the GPU draws it: light after light, each normal packed with its
/// kNN radius from `radii` (photon-map order), `offset` added to each position.
fn drawn_photons<'a>(
    traced: &'a Traced,
    radii: &'a [f32],
    offset: glam::Vec3,
) -> impl Iterator<Item = Photon> + 'a {
    debug_assert_eq!(traced.photon_count(), radii.len());
    traced.photons().zip(radii).map(move |(p, &r)| Photon {
        position: p.position + offset,
        normal: pack_normal(p.normal, r),
        ..*p
    })
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
    /// texels' jittered points (`ispm::texel_jitter`).
    sample: u32,
    kernel: KernelSettings,
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
    /// The kernel's scene-relative clamp, before the view's footprint floor.
    kernel_clamp: KernelSettings,
    /// Height of the image the estimate is made at (the low one when subsampling).
    estimate_height: u32,
    /// The full image size and the subsample factor: with the `view_proj` the frame gives each
    /// estimate, the screen the tiled estimator bins for.
    screen_size: ((u32, u32), u32),
    /// The tiled estimator's lists of the last recorded estimate.
    tile_stats: Option<crate::passes::photon_tiles::TileStats>,
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
    low: [Image; 2],
    /// The global photons' share of `low` and the pass that normalises it by its kernel's
    /// support on the surface (`passes/support.rs`).
    support: ([Image; 2], SupportPass),
    upsample: UpsamplePass,
    subsample: u32,
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
}

/// `transform` followed by a move of `-origin`, composed in f64.
fn relative_to(origin: glam::DVec3, transform: glam::Mat4) -> glam::Mat4 {
    let mut m = transform.as_dmat4();
    m.w_axis -= origin.extend(0.0);
    m.as_mat4()
}

/// `scene` with every instance moved by `-origin` (what the CPU trace's BVH is built from).
fn relative_scene(scene: &Scene, origin: glam::DVec3) -> Scene {
    let mut relative = scene.clone();
    for instance in &mut relative.instances {
        instance.transform = relative_to(origin, instance.transform);
    }
    relative
}

impl PhotonFrame {
    /// The photon part of `settings`' frame of `scene`, emitting from the lights of
    /// `effects`' photon mask, tracing at most `effects.max_bounces` bounces.
    pub fn new(
        gpu: &Arc<Gpu>,
        scene: &Scene,
        gpu_scene: &GpuScene,
        (settings, effects): (&RenderSettings, &EffectsPlan),
        targets: &PhotonTargets,
    ) -> anyhow::Result<Self> {
        let PhotonTargets {
            frame,
            gbuffer,
            radiance,
        } = *targets;
        // The photons' origin: fixed for the scene, so that the photon map is the same
        // whatever the camera (module docs).
        let origin = if gpu_scene.bounds.is_empty() {
            glam::DVec3::ZERO
        } else {
            gpu_scene.bounds.center().as_dvec3()
        };
        // The effects plan's split of the photons over its lights, taken as it is.
        let budget = effects.photon_budget();
        let caustic_share = settings.caustic_share;
        let plan_for = |scene: &Scene, budget: &[Option<usize>]| {
            let bounds = &gpu_scene.bounds;
            let plan = BouncePlan::with_budget(scene, budget, origin, bounds, caustic_share);
            if settings.whole_light_grids {
                plan.whole_grids()
            } else {
                plan
            }
        };
        let plan = timing::timed("bounce plan", || plan_for(scene, &budget));
        // Room for every light too: `set_lights` may bring back a light the plan skips now,
        // and move lights (caustic views change size: `BouncePlan::capacity`). Not a frame's
        // split but the buffers' size: the photons as if every light emitted, by power.
        let every = |scene: &Scene| -> Vec<Option<usize>> {
            photon_budget(scene, settings.photons)
                .into_iter()
                .map(Some)
                .collect()
        };
        let mut capacity = plan
            .capacity()
            .max(plan_for(scene, &every(scene)).capacity());
        // And for every pose of an animated scene, so that its caustic views keep their
        // subdivision (`BouncePlan::within` lowers it only for what was not foreseen).
        if scene.is_animated() {
            let period = scene.animations.period();
            let mut posed = scene.clone();
            for k in 0..POSE_SAMPLES {
                posed.set_pose(&scene.pose_at(period * k as f32 / POSE_SAMPLES as f32));
                capacity = capacity.max(plan_for(&posed, &every(&posed)).capacity());
            }
        }
        let (views, texels) = (capacity.views.max(1), capacity.texels.max(1));
        let light_gbuffer = GBuffer::new(
            gpu,
            "light_gbuffer",
            capacity.extent.0.max(1),
            capacity.extent.1.max(1),
            views as u32,
            ViewKind::D2Array,
        )?;
        let light_pass = LightGBufferPass::new(gpu, gpu_scene, views)?;
        let view_buffer = Buffer::constants(
            gpu,
            "bounce_map.views",
            (views * size_of::<crate::layout::BounceView>()) as u64,
            vk::BufferUsageFlags::STORAGE_BUFFER,
        )?;
        // Hard case "more photons than fit in one buffer": split over buffers of at most one
        // storage buffer's reach.
        let range = storage_buffer_range(gpu, settings);
        let bounce_map = BounceBuffers::new(gpu, texels, range)
            .with_context(|| format!("{} photons", settings.photons))?;
        let bounce_bytes = (texels * size_of::<BounceMapPhoton>()) as u64;
        let readback = Buffer::new(
            gpu,
            "bounce_map.readback",
            bounce_bytes,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        let bounce_pass = BounceMapPass::new(
            gpu,
            &BounceMapIo {
                materials: &gpu_scene.materials,
                views: &view_buffer,
                light_gbuffer: &light_gbuffer,
                bounce_map: &bounce_map.device,
                split: bounce_map.split,
            },
            settings.bsdf_variant,
        )?;
        let buffers = PhotonBuffers::new(gpu, 1, 1, photons_per_buffer(gpu, settings))?;
        let subsample = settings.subsample_factor();
        let (indirect, subsampled) = if subsample == 1 {
            let indirect = photon_volumes::target(gpu, radiance.width, radiance.height)?;
            (indirect, None)
        } else {
            let indirect = upsample::output(gpu, radiance.width, radiance.height)?;
            let (w, h) = upsample::low_size(radiance.width, radiance.height, subsample);
            let low = photon_volumes::low_targets(gpu, w, h)?;
            let inputs = UpsampleInputs {
                materials: &gpu_scene.materials,
                gbuffer,
                low: &low,
            };
            let upsample = UpsamplePass::new(
                gpu,
                &inputs,
                &indirect,
                subsample,
                settings.upsample,
                settings.bsdf_variant,
            )?;
            let images = photon_volumes::support_targets(gpu, w, h)?;
            let pass = SupportPass::new(gpu, (frame, gbuffer), (&low[0], Some(&low[1])), &images)?;
            let support = (images, pass);
            (
                indirect,
                Some(Subsampled {
                    low,
                    support,
                    upsample,
                    subsample,
                }),
            )
        };
        let support = if subsample == 1 {
            let images = photon_volumes::support_targets(gpu, radiance.width, radiance.height)?;
            let pass = SupportPass::new(gpu, (frame, gbuffer), (&indirect, None), &images)?;
            Some((images, pass))
        } else {
            None
        };
        let inputs = PhotonVolumeInputs {
            frame,
            photons: &buffers.device,
            materials: &gpu_scene.materials,
            gbuffer,
        };
        let estimator = match settings.density.resolve_for_device(&gpu.properties) {
            Density::Tiled => {
                let targets = estimate_targets(&indirect, support.as_ref(), subsampled.as_ref());
                Estimator::Tiled(PhotonTilesPass::new(
                    gpu,
                    &inputs,
                    subsample,
                    settings.bsdf_variant,
                    (FRAMES_IN_FLIGHT, &targets),
                )?)
            }
            Density::Volumes | Density::Auto => Estimator::Volumes(Box::new(
                PhotonVolumesPass::new(gpu, &inputs, subsample, settings.bsdf_variant)?,
            )),
        };
        let composite = CompositePass::new(gpu, &indirect, radiance)?;
        // The denoiser filters the global share the support pass normalised, within the
        // estimate it belongs to (the low-resolution irradiance when subsampling).
        let denoise = match settings.denoise {
            0 => None,
            levels => {
                let (total, global) = match (&subsampled, &support) {
                    (Some(sub), _) => (&sub.low[0], &sub.support.0[0]),
                    (None, Some((images, _))) => (&indirect, &images[0]),
                    (None, None) => unreachable!("the support targets exist at subsample 1"),
                };
                let pass = DenoisePass::new(gpu, gbuffer, (total, global), subsample)?;
                Some((pass, levels))
            }
        };
        let kernel_clamp =
            KernelSettings::scene_relative(&gpu_scene.bounds, settings.photons, settings.radius);
        let estimate_height = upsample::low_size(radiance.width, radiance.height, subsample).1;
        Ok(Self {
            gpu: gpu.clone(),
            scene: scene.clone(),
            // The instances the scene animates get a BVH level of their own, moved by transform
            // (`move_instances`); the static geometry's is built here, once. Relative to the
            // origin, as the photons are traced (position case: f32 world coordinates are 8 mm
            // apart 10⁵ m from the origin).
            bvh: SceneBvh::with_moving_instances(
                &relative_scene(scene, origin),
                &effects.motion.instances,
            ),
            trace: TraceSettings {
                max_bounces: effects.max_bounces,
                seed: settings.seed,
                // The plan's lobes (`Renderer::new` narrowed the settings' variant to them).
                variant: settings.bsdf_variant,
                // Only what the photon volumes can read (`StoreOn::EyeGBuffer`).
                store_on: StoreOn::EyeGBuffer,
            },
            base_seed: settings.seed,
            sample: 0,
            // The footprint floor of the image the estimate is made at (the low one when
            // subsampling).
            kernel: kernel_clamp.for_view(scene.camera.yfov, estimate_height),
            plan,
            capacity,
            caustic_share,
            whole_grids: settings.whole_light_grids,
            bounds: gpu_scene.bounds,
            light_gbuffer,
            light_pass,
            views: view_buffer,
            bounce_map,
            readback,
            bounce_pass,
            buffers,
            rebind: false,
            estimator,
            subsampled,
            indirect,
            support,
            composite,
            denoise,
            traced: Traced::default(),
            reuse_lights: settings.effects == Effects::Auto,
            neighbours: Neighbours::for_photons(settings.photons),
            radii: Vec::new(),
            retrace: Vec::new(),
            batches: Vec::new(),
            eye: scene.camera.position().as_dvec3(),
            kernel_clamp,
            estimate_height,
            screen_size: ((radiance.width, radiance.height), subsample),
            tile_stats: None,
        })
    }

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
        self.kernel.scale = scale;
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

    /// Whether this frame's [`Self::record_emission`] made bounce-map records to read back:
    /// a budget, a light with power, and a light whose photons are traced again.
    pub fn emits(&self) -> bool {
        !self.batches.is_empty()
    }

    /// Box A: the light views' uniforms, and the light G-buffers and bounce map of the lights
    /// whose photons are traced again (`retrace.rs`: the others' are kept); hands the bounce map
    /// to the transfer queue for [`Self::record_readback`], and the photon buffer (kept by the
    /// graphics queue while frames reuse the photon map) for [`Self::record_upload`]: the
    /// upload must wait for this submission.
    pub fn record_emission(&mut self, cmd: &Cmd, scene: &GpuScene) {
        let plan = &self.plan;
        let lights = self.scene.lights.len();
        self.retrace = self.traced.changed(plan, lights, self.reuse_lights);
        self.batches.clear();
        if plan.texels == 0 {
            // No photons this frame (the lights went dark): nothing to upload or draw, so the
            // photon buffer's hand-offs stay paired.
            self.buffers.counts.fill(0);
            return;
        }
        // Nothing when the photon buffer is not the graphics queue's (already handed over, or
        // a single queue family): the tracker knows who holds it.
        for (_, photons) in self.buffers.used() {
            cmd.release_buffer(photons, QueueRole::Transfer);
        }
        // The re-traced lights' views, consecutive ones in one batch, cut where the bounce map's
        // buffers end (`passes/bounce_map.rs`).
        let mut ranges: Vec<Range<usize>> = Vec::new();
        for views in (0..lights)
            .filter(|&l| self.retrace[l])
            .map(|l| plan.light_views(l))
            .filter(|r| !r.is_empty())
        {
            match ranges.last_mut() {
                Some(last) if last.end == views.start => last.end = views.end,
                _ => ranges.push(views),
            }
        }
        let view_records = |v: usize| plan.texel_range(v..v + 1);
        let extent = |v: usize| plan.extents[v];
        let split = self.bounce_map.split;
        self.batches = ranges
            .iter()
            .flat_map(|r| ViewBatch::split(r.clone(), view_records, extent, split))
            .collect();
        if self.batches.is_empty() {
            return; // every light's photons are kept: nothing to draw, read back or trace
        }
        self.light_pass.update(cmd, &plan.uniforms);
        cmd.update_buffer(&self.views, 0, bytemuck::cast_slice(&plan.views));
        // Origin-relative models; each view's uniforms hold its light clip transform. The kept
        // lights' layers are not drawn (an empty extent): they hold what they held when those
        // lights were last traced, with the same views.
        let relative = scene.draws(plan.origin, None);
        let draws = vec![relative; plan.views.len()];
        let extents: Vec<(u32, u32)> = plan
            .extents
            .iter()
            .enumerate()
            .map(|(v, &e)| {
                if ranges.iter().any(|r| r.contains(&v)) {
                    e
                } else {
                    (0, 0)
                }
            })
            .collect();
        {
            let _scope = cmd.scope(PassId::LightGbuffers.name());
            self.light_pass
                .record(cmd, scene, &draws, &extents, &mut self.light_gbuffer);
        }
        let io = BounceMapIo {
            materials: &scene.materials,
            views: &self.views,
            light_gbuffer: &self.light_gbuffer,
            bounce_map: &self.bounce_map.device,
            split: self.bounce_map.split,
        };
        self.bounce_pass
            .record(cmd, &io, &self.batches, (self.trace.seed, self.sample));
        for buffer in &self.bounce_map.device {
            cmd.release_buffer(buffer, QueueRole::Transfer);
        }
    }

    /// The GPU→CPU copy of the bounce map's records this frame made (on the transfer queue),
    /// handing it back to the graphics queue.
    pub fn record_readback(&self, cmd: &Cmd) {
        if self.batches.is_empty() {
            return;
        }
        let _scope = cmd.scope(PassId::Readback.name());
        let record = size_of::<BounceMapPhoton>() as u64;
        let split = self.bounce_map.split;
        for buffer in &self.bounce_map.device {
            // Every buffer, also one without new records: each is handed back below.
            cmd.transition_buffer(buffer, Access::TransferSrc);
        }
        // Each buffer's new records to their places in the one readback buffer.
        for (b, buffer) in self.bounce_map.device.iter().enumerate() {
            let base = split.records_of(b).start;
            let regions: Vec<(Range<u64>, u64)> = self
                .batches
                .iter()
                .filter(|batch| batch.records.start / split.per_buffer == b)
                .map(|batch| {
                    let r = &batch.records;
                    let within = (r.start - base) as u64 * record..(r.end - base) as u64 * record;
                    (within, r.start as u64 * record)
                })
                .collect();
            cmd.copy_buffer_regions(buffer, &self.readback, &regions);
        }
        cmd.transition_buffer(&self.readback, Access::HostRead);
        for buffer in &self.bounce_map.device {
            cmd.release_buffer(buffer, QueueRole::Graphics);
        }
    }

    /// Box C, on the host once the readback has completed: traces the re-traced lights'
    /// bounce-map photons on every core, keeps the other lights' photons, and writes the photon
    /// map (light after light) into the staging buffer for [`Self::record_upload`]. The
    /// previous frame's upload must have completed.
    pub fn trace(&mut self) -> anyhow::Result<FrameStats> {
        let plan = &self.plan;
        let mut stats = FrameStats {
            bounce_map_records: plan.texels,
            lights_at_max_resolution: plan.lights_at_max_resolution.clone(),
            ..Default::default()
        };
        if plan.texels == 0 {
            self.buffers.counts.fill(0);
            self.traced.clear();
            self.radii.clear();
            return Ok(stats);
        }
        anyhow::ensure!(
            self.retrace.len() == self.scene.lights.len(),
            "the photon trace ran without its emission"
        );
        // Only the re-traced lights' records, straight from the mapped readback.
        let readback = &self.readback;
        let mut read = |texels: Range<usize>, out: &mut [BounceMapPhoton]| {
            let offset = (texels.start * size_of::<BounceMapPhoton>()) as u64;
            readback.read_into(offset, bytemuck::cast_slice_mut(out))
        };
        let frame = retrace::Frame {
            plan,
            scene: &self.scene,
            bvh: &self.bvh,
            trace: &self.trace,
            retrace: &self.retrace,
            sample: self.sample,
        };
        self.traced.update(&frame, &mut read, &mut stats)?;
        // The kernel radii over every light's photons (module docs, "Kernel radii"), before
        // anything can fail: the radii always match the kept photons.
        let (traced, neighbours) = (&self.traced, self.neighbours);
        self.radii = timing::timed("photon density", || knn_radii(traced.photons(), neighbours));
        let count = self.traced.photon_count();
        if !self.buffers.holds(count) {
            // The old buffers go to the graveyard, destroyed once the frames using them finish.
            // The photons that were on the graphics queue were released in `record_emission`
            // (they have none now: the new buffers start out owned by nobody).
            let per_buffer = self.buffers.per_buffer;
            let capacity = count.next_power_of_two();
            self.buffers = PhotonBuffers::new(&self.gpu, count, capacity, per_buffer)?;
            self.rebind = true;
        }
        // Light after light, each light's photons where a fresh map has them, normals packed
        // with their radii, a chunk at a time.
        let mut drawn = drawn_photons(&self.traced, &self.radii, glam::Vec3::ZERO);
        let chunks = std::iter::from_fn(|| {
            let chunk: Vec<Photon> = drawn.by_ref().take(WRITE_CHUNK).collect();
            (!chunk.is_empty()).then_some(chunk)
        });
        timing::timed("upload write", || self.buffers.write(chunks))?;
        stats.photon_buffers = self.buffers.counts.iter().filter(|&&n| n > 0).count();
        stats.bounce_map_buffers = self.bounce_map_buffers();
        Ok(stats)
    }

    /// Buffers of the bounce map holding this frame's records.
    fn bounce_map_buffers(&self) -> usize {
        let split = self.bounce_map.split;
        split.pieces(0..self.plan.texels).count()
    }

    /// Whether [`Self::trace`] left photons to upload and draw.
    pub fn has_photons(&self) -> bool {
        self.count() > 0
    }

    /// Photons in the photon map this frame.
    fn count(&self) -> u32 {
        self.buffers.counts.iter().sum()
    }

    /// The CPU→GPU copy of the photon map (on the transfer queue), handing it to the graphics
    /// queue for [`Self::record_estimate`].
    pub fn record_upload(&self, cmd: &Cmd) {
        if self.count() == 0 {
            return;
        }
        let _scope = cmd.scope(PassId::Upload.name());
        for (staging, photons) in self.buffers.used() {
            cmd.copy_buffer(staging, photons);
            cmd.release_buffer(photons, QueueRole::Graphics);
        }
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
        drawn_photons(&self.traced, &self.radii, self.eye_offset()).collect()
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
