//! Setting up the photon part of a frame ([`PhotonFrame::new`]): the bounce plan and the
//! buffers' capacity (every light, every pose of an animated scene), the light G-buffers, the
//! bounce map and its readback (box A), the photon buffers (box C's upload), the density
//! estimator, subsampling, support, denoise and composite targets and passes (box D), and the
//! CPU trace's BVH, built once relative to the scene's centre (`photon_frame.rs`'s module docs).

use super::buffers::{photons_per_buffer, storage_buffer_range, BounceBuffers, PhotonBuffers};
use super::retrace::Traced;
use super::{
    estimate_targets, relative_to, Estimator, FinePhotons, PhotonFrame, PhotonTargets, Subsampled,
};
use crate::config::settings::Effects;
use crate::config::settings::{Density, RenderSettings, FRAMES_IN_FLIGHT};
use crate::gpu::scene::GpuScene;
use crate::gpu::{vk, Buffer, Gpu, Image, MemoryLocation, ViewKind};
use crate::passes::bounce_map::{BounceMapIo, BounceMapPass};
use crate::passes::composite::CompositePass;
use crate::passes::denoise::DenoisePass;
use crate::passes::eye_gbuffer::GBuffer;
use crate::passes::light_gbuffer::LightGBufferPass;
use crate::passes::photon_tiles::PhotonTilesPass;
use crate::passes::photon_volumes::{self, PhotonVolumeInputs, PhotonVolumesPass};
use crate::passes::support::SupportPass;
use crate::passes::upsample::{self, UpsampleInputs, UpsamplePass};
use crate::passes::value_check;
use crate::photon::bvh::SceneBvh;
use crate::photon::density::Neighbours;
use crate::photon::emit::photon_budget;
use crate::photon::kernel::KernelSettings;
use crate::photon::trace::{StoreOn, TraceSettings};
use crate::photon::types::BounceMapPhoton;
use crate::plan::bounce_plan::BouncePlan;
use crate::plan::EffectsPlan;
use crate::scene::Scene;
use crate::timing;
use anyhow::Context;
use std::sync::Arc;

/// Poses of an animated scene over one period that the buffers are sized for.
const POSE_SAMPLES: usize = 24;

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
            lambert,
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
        );
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
        let inputs = PhotonVolumeInputs {
            frame,
            photons: &buffers.device,
            materials: &gpu_scene.materials,
            gbuffer,
        };
        let density = settings.density.resolve_for_device(&gpu.properties);
        let estimator = |subsample: u32, targets: &[&Image]| -> anyhow::Result<Estimator> {
            let variant = settings.bsdf_variant;
            Ok(match density {
                Density::Tiled => Estimator::Tiled(PhotonTilesPass::new(
                    gpu,
                    &inputs,
                    (subsample, variant, settings.tile_order),
                    (FRAMES_IN_FLIGHT, targets),
                )?),
                Density::Volumes | Density::Auto => Estimator::Volumes(Box::new(
                    PhotonVolumesPass::new(gpu, &inputs, (subsample, targets), variant)?,
                )),
            })
        };
        let kernel_clamp =
            KernelSettings::scene_relative(&gpu_scene.bounds, settings.photons, settings.radius);
        // The fine photons at full resolution when subsampling (`estimate.rs`).
        let caustics_apart = subsample > 1 && effects.fine_photons.needed;
        let (width, height) = (radiance.width, radiance.height);
        let (indirect, subsampled) = if subsample == 1 {
            (photon_volumes::target(gpu, width, height), None)
        } else {
            let indirect = match caustics_apart && density != Density::Tiled {
                // The fine photons' volumes draw into it (the tiled gather writes it as the
                // upsample does, as a storage image).
                true => photon_volumes::target(gpu, width, height),
                false => upsample::output(gpu, width, height),
            };
            let fine = match caustics_apart {
                true => {
                    // The photon volumes draw into three targets; the tiled gather adds to
                    // `indirect` alone.
                    let support = match density {
                        Density::Tiled => None,
                        _ => Some(photon_volumes::support_targets(gpu, width, height)),
                    };
                    let targets: Vec<&Image> = std::iter::once(&indirect)
                        .chain(support.iter().flatten())
                        .collect();
                    Some(FinePhotons {
                        estimator: estimator(1, &targets)?,
                        support,
                    })
                }
                false => None,
            };
            let (w, h) = upsample::low_size(width, height, subsample);
            let low = photon_volumes::low_targets(gpu, w, h);
            for image in &low {
                // Read back by `read_low` (tests).
                image.require(vk::ImageUsageFlags::TRANSFER_SRC, "a read-back");
            }
            let lambert = lambert.ok_or_else(|| {
                anyhow::anyhow!(
                    "internal: a subsampled estimate without the direct pass's c_L/π image"
                )
            })?;
            let upsample_inputs = UpsampleInputs {
                gbuffer,
                lambert,
                low: &low,
            };
            let upsample = UpsamplePass::new(
                gpu,
                &upsample_inputs,
                &indirect,
                subsample,
                settings.upsample,
            )?;
            let images = photon_volumes::support_targets(gpu, w, h);
            let pass = SupportPass::new(gpu, (frame, gbuffer), (&low[0], Some(&low[1])), &images)?;
            let support = (images, pass);
            (
                indirect,
                Some(Subsampled {
                    fine,
                    low,
                    support,
                    upsample,
                    subsample,
                }),
            )
        };
        let support = if subsample == 1 {
            let images = photon_volumes::support_targets(gpu, width, height);
            // Read back by `read_support_fraction` (tests).
            images[1].require(vk::ImageUsageFlags::TRANSFER_SRC, "a read-back");
            let pass = SupportPass::new(gpu, (frame, gbuffer), (&indirect, None), &images)?;
            Some((images, pass))
        } else {
            None
        };
        if settings.check_values {
            value_check::watch(&indirect);
            subsampled
                .iter()
                .flat_map(|s| &s.low)
                .for_each(value_check::watch);
        }
        let targets = estimate_targets(&indirect, support.as_ref(), subsampled.as_ref());
        let estimator = estimator(subsample, &targets)?;
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
        let estimate_height = upsample::low_size(width, height, subsample).1;
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
            yfov: scene.camera.yfov,
            estimate_height,
            screen_size: ((width, height), subsample),
            tile_stats: None,
            caustic_photons: 0,
            packed: Vec::new(),
        })
    }
}
