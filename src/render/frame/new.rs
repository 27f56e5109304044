//! Making a [`Renderer`]: the scene on the GPU, the effects plan, the images and passes the
//! plan calls for, the photon and translucent parts (`photon_frame.rs`, `translucent_frame.rs`),
//! and the frame slots.

use super::{constants, FrameSlot, Renderer, SHADOW_FACE_MARGIN};
use crate::config::settings::{Density, Method, RenderSettings, FRAMES_IN_FLIGHT};
use crate::gpu::scene::GpuScene;
use crate::gpu::{vk, Gpu, Image, ImageDesc, Timestamps, ViewKind};
use crate::layout::FrameUniforms;
use crate::passes::accumulate::AccumulatePass;
use crate::passes::direct::{self, DirectInputs, DirectOutputs, DirectPass};
use crate::passes::eye_gbuffer::{EyeGBufferPass, GBuffer};
use crate::passes::shadow_map::ShadowMapPass;
use crate::passes::tonemap::TonemapPass;
use crate::passes::value_check::ValueCheckPass;
use crate::passes::{shadow_map, tonemap, value_check};
use crate::photon::bsdf::BsdfVariant;
use crate::plan::lighting::LightSetup;
use crate::plan::SceneAnalysis;
use crate::render::photon_frame::{PhotonFrame, PhotonTargets};
use crate::render::translucent_frame::{TranslucentFrame, TranslucentResources};
use crate::scene::Scene;
use crate::timing::pass_id::PassId;
use std::sync::Arc;

impl Renderer {
    pub fn new(gpu: &Arc<Gpu>, scene: &Scene, settings: RenderSettings) -> anyhow::Result<Self> {
        // The density estimator for this device, before the plan lists it.
        let settings = RenderSettings {
            density: settings.density.resolve_for_device(&gpu.properties),
            ..settings
        };
        anyhow::ensure!(
            settings.density != Density::Tiled || gpu.properties.compute_subgroup_gather,
            "--density tiled: {} lacks the compute-shader subgroup operations the tiled gather \
             needs (basic, vote, arithmetic, ballot, shuffle); use --density volumes",
            gpu.properties.name
        );
        anyhow::ensure!(
            settings.method.is_gpu(),
            "--method {} is a CPU reference (`reference::render`), not a GPU frame",
            settings.method.name()
        );
        anyhow::ensure!(
            settings.width > 0 && settings.height > 0,
            "image size {}x{} is empty",
            settings.width,
            settings.height
        );
        // Emissive surfaces are lights: the scene's lights, then the area samples of frame 0.
        let emitters = crate::scene::emitters::Emitters::of(scene);
        let scene_lights = scene.lights.len();
        let mut source = scene.clone();
        source
            .lights
            .extend(emitters.lights(scene, 0, settings.emitter_lights));
        let scene = &source;
        let analysis = SceneAnalysis::new(scene, &settings);
        let plan = analysis.plan(scene, &scene.camera);
        log::info!("{plan}");
        let mut settings = settings;
        // The planned lobes, within the ones the settings allow (with `--effects all` the plan
        // needs every lobe).
        let planned = plan.bsdf_variant();
        settings.bsdf_variant = BsdfVariant {
            glossy: settings.bsdf_variant.glossy && planned.glossy,
            delta: settings.bsdf_variant.delta && planned.delta,
        };
        let gpu_scene = GpuScene::new(gpu, scene)?;
        // Sized for every light: a light the plan skips may come back after `set_lights`.
        let setup = LightSetup::new(
            &scene.lights,
            scene.camera.position().as_dvec3(),
            &gpu_scene.bounds,
            settings.shadow_resolution,
            SHADOW_FACE_MARGIN,
        );
        let frame_uniforms = constants(
            gpu,
            "frame.uniforms",
            size_of::<FrameUniforms>(),
            vk::BufferUsageFlags::UNIFORM_BUFFER,
        )?;
        let light_buffer = constants(
            gpu,
            "frame.lights",
            size_of::<crate::layout::GpuLight>() * setup.lights.len().max(1),
            vk::BufferUsageFlags::STORAGE_BUFFER,
        )?;
        let view_buffer = constants(
            gpu,
            "frame.shadow_views",
            size_of::<crate::layout::ShadowView>() * setup.views.len().max(1),
            vk::BufferUsageFlags::STORAGE_BUFFER,
        )?;
        let gbuffer = GBuffer::new(
            gpu,
            "eye_gbuffer",
            settings.width,
            settings.height,
            1,
            ViewKind::D2,
        );
        for image in gbuffer.colours() {
            // Read back by `read_gbuffer` (tests).
            image.require(vk::ImageUsageFlags::TRANSFER_SRC, "a read-back");
        }
        let shadow_atlas =
            shadow_map::atlas(gpu, settings.shadow_resolution, setup.views.len() as u32);
        // Planned, as are the G-buffer, the shadow atlas and the other images the passes
        // share: each pass declares its use as it is made below, and `make_planned` at the end
        // makes every image with the union (`gpu/image.rs`). Its own use: read back.
        let radiance = Image::planned(
            gpu,
            &ImageDesc {
                name: "radiance",
                format: vk::Format::R32G32B32A32_SFLOAT,
                width: settings.width,
                height: settings.height,
                layers: 1,
                usage: vk::ImageUsageFlags::TRANSFER_SRC,
                view: ViewKind::D2,
            },
        );
        // Made whenever ISPM subsamples, even where the plan needs no indirect light yet: the
        // photon part of the frame may be made later, when the camera moves (`set_camera`),
        // and the direct pass writing it is made once, here.
        let lambert = (settings.method == Method::Ispm && settings.subsample_factor() > 1)
            .then(|| direct::lambert_output(gpu, settings.width, settings.height));
        let display = tonemap::output(gpu, settings.width, settings.height);
        let accumulate =
            if settings.accumulate && (settings.method == Method::Ispm || plan.accumulate) {
                Some(AccumulatePass::new(gpu, &radiance)?)
            } else {
                None
            };
        let shadow_maps = ShadowMapPass::new(gpu)?;
        let eye_gbuffer =
            EyeGBufferPass::new(gpu, PassId::EyeGbuffer, &gpu_scene, &[&frame_uniforms])?;
        let direct = DirectPass::new(
            gpu,
            &DirectInputs {
                frame: &frame_uniforms,
                materials: &gpu_scene.materials,
                lights: &light_buffer,
                shadow_views: &view_buffer,
                gbuffer: &gbuffer,
                shadow_atlas: &shadow_atlas,
            },
            &DirectOutputs {
                radiance: &radiance,
                lambert: lambert.as_ref(),
            },
            settings.bsdf_variant,
        )?;
        let tonemap = TonemapPass::new(gpu, &radiance, &display)?;
        let value_check = if settings.check_values {
            value_check::watch(&radiance);
            Some(ValueCheckPass::new(gpu, FRAMES_IN_FLIGHT)?)
        } else {
            None
        };
        // Without indirect light (`--method direct`, `--bounces 0`, nothing to store photons on,
        // no light that emits any, ...) there is no photon part of the frame at all.
        let photons = if plan.indirect.needed {
            Some(PhotonFrame::new(
                gpu,
                scene,
                &gpu_scene,
                (&settings, &plan),
                &PhotonTargets {
                    frame: &frame_uniforms,
                    gbuffer: &gbuffer,
                    radiance: &radiance,
                    lambert: lambert.as_ref(),
                },
            )?)
        } else {
            None
        };
        let translucent = if plan.translucent.needed {
            TranslucentFrame::new(
                gpu,
                scene,
                &gpu_scene,
                &TranslucentResources {
                    frame: &frame_uniforms,
                    lights: &light_buffer,
                    shadow_views: &view_buffer,
                    shadow_atlas: &shadow_atlas,
                },
                (&gbuffer.depth, &radiance),
                settings.bsdf_variant,
            )?
        } else {
            None
        };
        // Every pass is made, and has declared its uses: the planned images can be made.
        gpu.make_planned()?;
        let slots = (0..FRAMES_IN_FLIGHT)
            .map(|i| {
                Ok(FrameSlot {
                    timestamps: Timestamps::new(gpu, &format!("frame[{i}].timestamps"), 64)?,
                    pending: None,
                })
            })
            .collect::<anyhow::Result<Vec<_>>>()?;
        Ok(Self {
            gpu: gpu.clone(),
            settings,
            camera: scene.camera,
            lights: scene.lights.clone(),
            scene_lights,
            emitters,
            emitter_sample: 0,
            source,
            plan,
            analysis,
            photon_map: None,
            scene: gpu_scene,
            frame_uniforms,
            light_buffer,
            view_buffer,
            gbuffer,
            shadow_atlas,
            radiance,
            lambert,
            display,
            shadow_maps,
            eye_gbuffer,
            direct,
            tonemap,
            value_check,
            photons,
            translucent,
            accumulate,
            accumulated: 0,
            still: false,
            last_sample: 0,
            slots,
            frame_index: 0,
            broken: false,
            last_frame_done: None,
            last_upload: None,
            last_retired: None,
            debug_view: None,
            static_enclosures: None,
        })
    }
}
