//! The frame, as a short script of named steps on timeline semaphores (the paper's Figure 3).
//!
//! ```text
//!  host   ─ prepare ─ record A ─ record B ─ wait(readback) ─ cpu_trace ─ record upload, D ─► next frame
//!                        │           │            ▲                 │           │
//!  graphics queue    [ box A ]──┐ [ box B ] ......│.................│......[ box D ]
//!                    constants, │ shadow maps,    │                 │      photon volumes,
//!                    light      │ eye G-buffer,   │                 │      denoise, upsample,
//!                    G-buffers, │ direct          │                 │      composite,
//!                    bounce map │                 │                 │      translucent, tonemap
//!                               │                 │                 │          ▲
//!  transfer queue               └─►[ readback ]───┘                 └─►[ upload ]
//! ```
//!
//! [`Renderer::submit_frame`] issues box A, the bounce map's copy to the host, and box B; then
//! the host waits for the copy only and traces the photons on every core (box C) while the GPU
//! draws box B (on a CPU device the default schedule waits for box B first,
//! [`Schedule::trace_beside_box_b`]) (in scenes with glass or mirrors it then gathers the photons' light seen from
//! the environment cube's centre, `photon_frame/environment.rs`, and waits for the previous
//! frame's box D before it writes that cube's staging buffer); then it issues the photon map's
//! upload and box D, which waits for it. Every
//! cross-queue dependency is a wait on a queue's timeline; the bounce map and the photon buffer
//! change queue-family ownership with release/acquire barriers where the transfer queue is a
//! family of its own (`Cmd::release_buffer`). Per-frame constants go through the command stream
//! (`Cmd::update_buffer`), so [`FRAMES_IN_FLIGHT`] frames can be in flight without the host
//! writing memory an earlier frame still reads; a frame slot's timestamps are read when the
//! slot comes round again (or in [`Renderer::finish`]). [`Schedule::Serial`] waits after every
//! submission: the same work strictly in order, the baseline `ispm bench` compares against.
//!
//! The effects plan (`plan.rs`, issue #9) decides which of these steps exist, which lights they
//! cover and which BSDF lobes their shaders compile; while no light changes and no instance
//! moves, frames after the first reuse its photon map (no light G-buffers, bounce map, readback,
//! trace or upload), and a camera move ([`Renderer::set_camera`]) keeps it: the photon map does
//! not depend on the camera (`photon_frame.rs`); when a light changes, only the lights whose
//! planned views changed are re-traced, the others' photons kept (`photon_frame/retrace.rs`).
//! `docs/effects.md`: the rules and the measured
//! equivalence with `--effects all`. Moving instances and posing an animated scene:
//! `frame/motion.rs`.

use crate::gpu::{
    vk, Buffer, Cmd, Gpu, Image, ImageDesc, QueueRole, Recording, Span, TimelinePoint, Timestamps,
    ViewKind, Wait,
};
use crate::gpu_scene::GpuScene;
use crate::layout::FrameUniforms;
use crate::lighting::LightSetup;
use crate::pass_id::PassId;
use crate::passes::accumulate::AccumulatePass;
use crate::passes::debug_view::{DebugInputs, DebugView, DebugViewPass};
use crate::passes::direct::{DirectInputs, DirectPass};
use crate::passes::eye_gbuffer::{EyeGBufferPass, GBuffer, View};
use crate::passes::shadow_map::{self, ShadowMapPass};
use crate::passes::tonemap::{self, Tonemap, TonemapPass};
use crate::passes::value_check::ValueCheckPass;
pub use crate::passes::value_check::{BufferCheck, Checked, ValueCheck};
use crate::photon::bsdf::BsdfVariant;
use crate::photon_frame::{PhotonFrame, PhotonTargets};
use crate::plan::{Effects, EffectsPlan, SceneAnalysis};
use crate::scene::{Camera, Light, Scene};
use crate::timing;
use crate::translucent_frame::{TranslucentFrame, TranslucentResources};
use glam::{DMat4, UVec4, Vec4};
use std::sync::Arc;

mod emission;
mod motion;

/// Texels by which shadow cube faces overlap (normal offset 1.5 + PCF 1 + bilinear 0.5).
const SHADOW_FACE_MARGIN: u32 = 3;

pub use crate::passes::photon_tiles::TileStats;
pub use crate::settings::{
    Density, Method, RenderSettings, Schedule, SkippedPass, FRAMES_IN_FLIGHT,
};
pub use crate::stats::{pass_ran, FrameImage, FrameStats, ReusedLight};
use crate::stats::{skipped, REUSE_SKIPS};

/// What a frame that reuses the photon map of frame `from` (traced with `traced`, for
/// `lights`) reports: built once, when that map is traced.
fn reuse_stats(from: u64, traced: &FrameStats, lights: &[Light]) -> FrameStats {
    let reason =
        format!("photon map of frame {from} reused: nothing moved and no light changed since");
    let what = format!("the photon map of frame {from} reused");
    let mut reused: Vec<usize> = traced.lights_reused.iter().map(|l| l.light).collect();
    reused.extend(&traced.lights_retraced);
    reused.sort_unstable();
    FrameStats {
        cpu_trace_ms: 0.0,
        passes_skipped: skipped(REUSE_SKIPS, &reason),
        lights_retraced: Vec::new(),
        lights_reused: reused
            .into_iter()
            .map(|l| ReusedLight::new(l, &lights[l].name, &what))
            .collect(),
        traced_bounce_map_photons: 0,
        ..traced.clone()
    }
}

/// Renders frames of one scene at one size.
pub struct Renderer {
    gpu: Arc<Gpu>,
    settings: RenderSettings,
    camera: Camera,
    /// The scene's lights, then the emitters' area samples (`frame/emission.rs`).
    lights: Vec<Light>,
    /// How many of `lights` are the scene's own (the rest are area samples).
    scene_lights: usize,
    /// The scene's emissive surfaces, and the photon sample their area samples are placed for.
    emitters: crate::scene::emitters::Emitters,
    emitter_sample: u32,
    /// The scene as loaded, with the current lights (the plan is re-made from it when they
    /// change).
    source: Scene,
    /// What the frame needs (`settings.effects == All`: everything).
    plan: EffectsPlan,
    /// The scene's camera- and light-independent analysis, which the plan is re-made from when
    /// the camera moves or a light changes.
    analysis: SceneAnalysis,
    /// While the photon map the photon buffer holds is still valid (no light changed since;
    /// never under `--effects all`): the stats a frame that reuses it reports.
    photon_map: Option<FrameStats>,
    scene: GpuScene,
    frame_uniforms: Buffer,
    light_buffer: Buffer,
    view_buffer: Buffer,
    gbuffer: GBuffer,
    shadow_atlas: Image,
    radiance: Image,
    display: Image,
    shadow_maps: ShadowMapPass,
    eye_gbuffer: EyeGBufferPass,
    direct: DirectPass,
    tonemap: TonemapPass,
    /// `RenderSettings::check_values`: the GPU's count of bad values.
    value_check: Option<ValueCheckPass>,
    photons: Option<PhotonFrame>,
    /// Glass and mirrors (scenes with delta materials only).
    translucent: Option<TranslucentFrame>,
    /// `RenderSettings::accumulate`: the running mean of still frames.
    accumulate: Option<AccumulatePass>,
    /// Frames in the accumulation after the last submitted frame.
    accumulated: u32,
    /// Nothing that changes the image has changed since the last submitted frame: the next
    /// one may join its accumulation.
    still: bool,
    /// The last photon sample drawn for an accumulated frame (`PhotonFrame::set_sample`).
    last_sample: u32,
    slots: Vec<FrameSlot>,
    /// Frames submitted so far.
    frame_index: u64,
    /// A frame failed half way through being issued ([`Renderer::submit_frame`]).
    broken: bool,
    /// The last submitted frame's final point (its photon volumes read the photon buffer).
    last_frame_done: Option<TimelinePoint>,
    /// The last photon-map upload (it reads the staging buffer the next trace writes).
    last_upload: Option<TimelinePoint>,
    /// The newest retired frame's GPU spans and stats (the viewer's live times).
    last_retired: Option<(Vec<Span>, FrameStats)>,
    /// An intermediate buffer shown instead of the frame, and the pass that shows it (made
    /// when first recorded, again when its inputs change).
    debug_view: Option<(DebugView, Option<DebugViewPass>)>,
    /// The closed surfaces of the instances that do not move, welded the first time animated
    /// instances move (`frame/motion.rs`).
    static_enclosures: Option<crate::plan::StaticEnclosures>,
}

/// What one frame in flight keeps until it is retired.
struct FrameSlot {
    timestamps: Arc<Timestamps>,
    pending: Option<PendingFrame>,
}

struct PendingFrame {
    done: TimelinePoint,
    stats: FrameStats,
    /// When the host began issuing it ([`timing::now_ns`]).
    start_ns: u64,
    index: u64,
}

/// The host's set-up of one frame.
struct FrameSetup {
    camera_pos: glam::DVec3,
    setup: LightSetup,
    uniforms: FrameUniforms,
    shadow_draws: Vec<Vec<crate::gpu_scene::Draw>>,
    eye_draws: Vec<crate::gpu_scene::Draw>,
    delta_draws: Vec<crate::gpu_scene::Draw>,
}

/// A camera the renderer can use: finite, with a field of view in (0, π) and a near plane > 0.
fn check_camera(camera: &Camera) -> anyhow::Result<()> {
    anyhow::ensure!(
        camera.transform.is_finite(),
        "camera: the transform is not finite"
    );
    anyhow::ensure!(
        camera.yfov.is_finite() && camera.yfov > 0.0 && camera.yfov < std::f32::consts::PI,
        "camera: yfov {} outside (0, π)",
        camera.yfov
    );
    anyhow::ensure!(
        camera.znear.is_finite() && camera.znear > 0.0,
        "camera: znear {} must be > 0",
        camera.znear
    );
    Ok(())
}

/// A wait for `point` before any work of the waiting submission.
fn after(point: TimelinePoint) -> Wait {
    Wait {
        point,
        stage: vk::PipelineStageFlags2::ALL_COMMANDS,
    }
}

fn constants(
    gpu: &Arc<Gpu>,
    name: &str,
    size: usize,
    usage: vk::BufferUsageFlags,
) -> anyhow::Result<Buffer> {
    Ok(Buffer::constants(gpu, name, size as u64, usage)?)
}

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
        )?;
        let shadow_atlas =
            shadow_map::atlas(gpu, settings.shadow_resolution, setup.views.len() as u32)?;
        let radiance = Image::new(
            gpu,
            &ImageDesc {
                name: "radiance",
                format: vk::Format::R32G32B32A32_SFLOAT,
                width: settings.width,
                height: settings.height,
                layers: 1,
                // Written by imageStore (direct, composite), then drawn over by the
                // translucent pass as a colour attachment.
                // TRANSFER_DST: the value check's test seam (`passes/value_check.rs`).
                usage: vk::ImageUsageFlags::STORAGE
                    | vk::ImageUsageFlags::COLOR_ATTACHMENT
                    | vk::ImageUsageFlags::SAMPLED
                    | vk::ImageUsageFlags::TRANSFER_SRC
                    | vk::ImageUsageFlags::TRANSFER_DST,
                view: ViewKind::D2,
            },
        )?;
        let display = tonemap::output(gpu, settings.width, settings.height)?;
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
            &radiance,
            settings.bsdf_variant,
        )?;
        let tonemap = TonemapPass::new(gpu, &radiance, &display)?;
        let value_check = if settings.check_values {
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
                gbuffer.depth.format,
                radiance.format,
                settings.bsdf_variant,
            )?
        } else {
            None
        };
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

    /// Camera-relative world → clip for the eye (reversed-Z, infinite far plane).
    fn eye_view_proj(&self) -> DMat4 {
        let c = self.camera.transform.as_dmat4();
        let rotation_only = DMat4::from_cols(c.x_axis, c.y_axis, c.z_axis, glam::DVec4::W);
        let aspect = f64::from(self.settings.width) / f64::from(self.settings.height);
        let proj = glam::dcamera::rh::proj::vulkan::perspective_infinite_reverse(
            f64::from(self.camera.yfov),
            aspect,
            f64::from(self.camera.znear),
        );
        proj * rotation_only.inverse()
    }

    /// Moves the scene's lights (the same lights in the same order, with new transforms or
    /// powers) for the next frame. The effects plan's light decisions are made again for them;
    /// the next frame traces the photons of the lights whose planned views changed again (a
    /// changed power shifts every light's budget) and keeps the others'. Fails when the moved
    /// lights call for indirect light this renderer was planned without (create a new one).
    pub fn set_lights(&mut self, lights: &[Light]) -> anyhow::Result<()> {
        anyhow::ensure!(
            lights.len() == self.scene_lights,
            "{} lights given, the scene has {}",
            lights.len(),
            self.scene_lights
        );
        if lights == self.lights() {
            return Ok(()); // nothing changed: the photon map stays valid
        }
        let mut all = lights.to_vec();
        all.extend_from_slice(&self.lights[self.scene_lights..]);
        self.apply_lights(&all)?;
        self.restart_accumulation(true);
        Ok(())
    }

    /// The frame's lights (the scene's and the area samples) become `lights`: the plan is made
    /// again for them and the photon part moved to them; the accumulation goes on.
    fn apply_lights(&mut self, lights: &[Light]) -> anyhow::Result<()> {
        // The shadow views were sized for the scene's lights: a light that changes kind (or a
        // spot whose cone needs a cube) may need more.
        let views = LightSetup::new(
            lights,
            self.camera.position().as_dvec3(),
            &self.scene.bounds,
            self.settings.shadow_resolution,
            SHADOW_FACE_MARGIN,
        )
        .views
        .len();
        let capacity = self.shadow_atlas.layers as usize;
        anyhow::ensure!(
            views <= capacity,
            "the changed lights need {views} shadow views, this renderer has {capacity}: create a \
             new renderer"
        );
        // In place (the scene's meshes are not copied every frame a light moves), and back if
        // the new lights do not fit this renderer.
        let before = std::mem::replace(&mut self.source.lights, lights.to_vec());
        let plan = match self.plan_lights(lights) {
            Ok(plan) => plan,
            Err(e) => {
                self.source.lights = before;
                return Err(e);
            }
        };
        if let Some(translucent) = &mut self.translucent {
            translucent.invalidate(); // the cube map holds direct light
        }
        if plan != self.plan {
            log::info!("{plan}");
        }
        self.lights = lights.to_vec();
        self.plan = plan;
        self.photon_map = None;
        Ok(())
    }

    /// The next frame starts a new accumulation (`RenderSettings::accumulate`): something that
    /// changes the image changed. When lights or objects `moved`, the photons go back to sample
    /// 0, the frame-coherent one, so a moving scene keeps its random numbers from frame to
    /// frame and does not shimmer (docs/stability.md); a camera move keeps the photon map.
    pub(crate) fn restart_accumulation(&mut self, moved: bool) {
        self.still = false;
        if moved {
            self.last_sample = 0;
            if let Some(photons) = &mut self.photons {
                photons.set_sample(0);
            }
        }
    }

    /// The plan for `self.source` with `lights` already in it, and the photon part moved to
    /// them ([`Self::set_lights`]).
    fn plan_lights(&mut self, lights: &[Light]) -> anyhow::Result<EffectsPlan> {
        let plan = self.analysis.plan(&self.source, &self.camera);
        anyhow::ensure!(
            !plan.indirect.needed || self.photons.is_some(),
            "the moved lights need indirect light ({}), which this renderer was planned without \
             ({}): create a new renderer",
            plan.indirect.reason,
            self.plan.indirect.reason
        );
        if let Some(photons) = &mut self.photons {
            photons.set_lights(lights, &plan.photon_budget())?;
        }
        Ok(plan)
    }

    /// Moves the eye for the next frame: position, orientation, field of view and near plane
    /// (the image size stays). Everything that depends on the camera follows it:
    ///
    /// - the eye's view and projection, and every camera-relative matrix and position (shadow
    ///   views, lights, instances, the environment map's centre), made in f64 each frame;
    /// - the effects plan's view-dependent decisions: which lights reach the visible scene
    ///   (shadow views, direct light) and which are enclosed away from every viewer (no
    ///   photons); when the photon lights change, the next frame traces a new photon map, and
    ///   a view that needs indirect light this renderer was planned without gets the photon
    ///   part of the frame now;
    /// - the photon volumes: the offset they draw the photon map with and the kernel's
    ///   pixel-footprint floor (field of view).
    ///
    /// What does not depend on the camera stays: the photon map (traced relative to the
    /// scene's centre, `photon_frame.rs`), so a pure camera move re-traces nothing (the frame's
    /// stats list the photon passes as skipped, the map reused); the environment cube map,
    /// centred on the glass and mirrors (re-rendered only if the lights it is shaded with
    /// change); the directional lights' shadow maps, fitted to the scene, not the view.
    /// Fails for a camera that is not finite, or has a field of view outside (0, π) or a
    /// near plane ≤ 0.
    pub fn set_camera(&mut self, camera: Camera) -> anyhow::Result<()> {
        check_camera(&camera)?;
        if camera == self.camera {
            return Ok(());
        }
        let plan = self.analysis.plan(&self.source, &camera);
        if plan.indirect.needed && self.photons.is_none() {
            // Every photon light was enclosed away from the old view: the photon part of the
            // frame is made now, as a new renderer for this camera would have it.
            let mut source = self.source.clone();
            source.camera = camera;
            self.photons = Some(PhotonFrame::new(
                &self.gpu,
                &source,
                &self.scene,
                (&self.settings, &plan),
                &PhotonTargets {
                    frame: &self.frame_uniforms,
                    gbuffer: &self.gbuffer,
                    radiance: &self.radiance,
                },
            )?);
            self.photon_map = None;
        } else if let Some(photons) = &mut self.photons {
            if plan.photon_mask() != self.plan.photon_mask() {
                photons.set_lights(&self.lights, &plan.photon_budget())?;
                self.photon_map = None;
            }
        }
        if let Some(photons) = &mut self.photons {
            photons.set_view(&camera);
        }
        if plan.direct_mask() != self.plan.direct_mask() {
            if let Some(translucent) = &mut self.translucent {
                translucent.invalidate(); // the cube map holds the direct light of these lights
            }
        }
        if plan != self.plan {
            log::debug!("{plan}");
        }
        self.camera = camera;
        self.source.camera = camera;
        self.plan = plan;
        self.restart_accumulation(false);
        Ok(())
    }

    /// Test seam of the value check (`passes/value_check.rs`): the next check of `buffer`
    /// finds `value` at its float `index` (an image's texel `index / 4`, channel `index % 4`,
    /// the texel's other channels 0; a record's float counted over the whole photon map when it
    /// is split over buffers), written just before the check reads it, so a test sees
    /// the counter catch a bad value in every kind of buffer (and later passes carry it on).
    /// Fails unless the renderer checks values (`RenderSettings::check_values`).
    pub fn inject_value(&mut self, buffer: Checked, index: u64, value: f32) -> anyhow::Result<()> {
        let check = self.value_check.as_mut().ok_or_else(|| {
            anyhow::anyhow!("inject_value needs a renderer made with check_values")
        })?;
        check.inject(buffer, index, value);
        Ok(())
    }

    /// The camera the next frame renders from.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The effects plan the frames follow (for the lights as they are now).
    pub fn plan(&self) -> &EffectsPlan {
        &self.plan
    }

    /// The scene's lights as the next frame uses them (without the emitters' area samples).
    pub fn lights(&self) -> &[Light] {
        &self.lights[..self.scene_lights]
    }

    /// Renders one frame, waits for it, and reads the images back.
    pub fn render(&mut self) -> anyhow::Result<FrameImage> {
        self.submit_frame()?;
        self.finish()
    }

    /// Issues one frame without waiting for the GPU to finish it (module docs: the schedule).
    /// At most [`FRAMES_IN_FLIGHT`] frames are in flight: the frame that last used this
    /// frame's slot is waited for first (in the steady state it has long finished).
    pub fn submit_frame(&mut self) -> anyhow::Result<()> {
        anyhow::ensure!(
            !self.broken,
            "the renderer stopped after an error in an earlier frame"
        );
        // Set until the frame is fully issued. The resources' tracked states stay consistent
        // after an error half way (a recording hands its states back only when submitted,
        // `gpu/tracker.rs`), but a buffer released to another queue family whose acquiring
        // submission never came (the bounce map, on a GPU with a transfer family) and the
        // slot's timestamp pool in use are not something the next frame can resume from, so
        // the renderer refuses further frames (the GPU is drained on drop).
        self.broken = true;
        let gpu = self.gpu.clone();
        let slot = (self.frame_index % FRAMES_IN_FLIGHT as u64) as usize;
        if let Some(retired) = self.retire_slot(slot)? {
            self.last_retired = Some(retired);
        }
        // The span covers the host's part of this frame only, so frames' spans never overlap
        // on the main thread's track.
        let frame_span = timing::frame(self.frame_index);
        let start_ns = timing::now_ns();
        gpu.collect_garbage();
        let timestamps = self.slots[slot].timestamps.clone();
        timestamps.reset(self.frame_index);
        // Progressive accumulation: a still frame joins the mean with a new photon sample (and
        // new points on the emitters, before the lights are set up).
        let accumulated = self.next_accumulation()?;
        let frame = self.prepare();
        // Nothing moved and no light changed since the photon map was traced: draw it again
        // (issue #9), without light G-buffers, bounce map, readback, trace or upload.
        let reuse = match &self.photon_map {
            Some(stats) if self.settings.effects == Effects::Auto => Some(stats),
            _ => None,
        };
        let mut stats = FrameStats::default();
        if let Some(reused) = reuse {
            stats = reused.clone();
        }
        let reuse = reuse.is_some();

        // Box A (graphics): per-frame constants, light G-buffers, bounce map.
        let a = gpu.record(QueueRole::Graphics, "box A", Some(timestamps.clone()))?;
        {
            let cmd = a.cmd();
            self.record_constants(&cmd, &frame);
            if let Some(photons) = &mut self.photons {
                if !reuse {
                    photons.record_emission(&cmd, &self.scene);
                }
            }
        }
        let a_done = self.submit(a, &[])?;

        // The bounce map's GPU→CPU copy (transfer queue).
        let emits = !reuse && self.photons.as_ref().is_some_and(PhotonFrame::emits);
        let readback_done = match &self.photons {
            Some(photons) if emits => {
                let rec = gpu.record(
                    QueueRole::Transfer,
                    PassId::Readback.name(),
                    Some(timestamps.clone()),
                )?;
                photons.record_readback(&rec.cmd());
                Some(self.submit(rec, &[after(a_done)])?)
            }
            _ => None,
        };

        // Box B (graphics): shadow maps, eye G-buffer, direct light.
        let b = gpu.record(QueueRole::Graphics, "box B", Some(timestamps.clone()))?;
        self.record_eye_and_direct(&b.cmd(), &frame);
        let b_done = self.submit(b, &[])?;
        // `Schedule::trace_beside_box_b`: on a CPU device the trace waits for box B (the serial
        // schedule has already waited for it).
        let schedule = self.settings.schedule;
        if !reuse
            && self.photons.is_some()
            && schedule != Schedule::Serial
            && !schedule.trace_beside_box_b(gpu.properties.device_type)
        {
            // The span's name is the reason, in the trace and the stats.
            timing::timed("box B wait: CPU device", || gpu.wait(b_done))?;
        }

        // Box C (host, all cores): trace the bounce map's photons while box B runs.
        let mut upload_done = None;
        if let (Some(photons), false) = (&mut self.photons, reuse) {
            if let Some(readback) = readback_done {
                timing::timed("readback wait", || gpu.wait(readback))?;
            }
            if let Some(previous) = self.last_upload.take() {
                // The staging buffer is free again (long done by now): the trace writes it,
                // also when every light's photons were kept.
                gpu.wait(previous)?;
            }
            // Without photons to emit (every light's mask off) the map is emptied.
            stats = photons.trace()?;
            // What glass and mirrors see of this map's indirect light
            // (`photon_frame/environment.rs`), gathered while the GPU still runs; the staging
            // buffer it goes to was read at most by the previous frame's box D.
            if let Some(translucent) = &mut self.translucent {
                let centre = translucent.centre();
                let texels = timing::timed("environment indirect", || {
                    photons.environment_indirect(centre)
                });
                if let Some(previous) = self.last_frame_done {
                    timing::timed("environment wait", || gpu.wait(previous))?;
                }
                translucent.set_indirect(&texels)?;
            }
            // The photon map's CPU→GPU copy (transfer queue), after the previous frame's
            // photon volumes stopped reading the photon buffer and box A handed it over.
            if photons.has_photons() {
                let rec = gpu.record(
                    QueueRole::Transfer,
                    PassId::Upload.name(),
                    Some(timestamps.clone()),
                )?;
                photons.record_upload(&rec.cmd());
                let waits: Vec<Wait> = self
                    .last_frame_done
                    .into_iter()
                    .chain([a_done])
                    .map(after)
                    .collect();
                let done = self.submit(rec, &waits)?;
                upload_done = Some(done);
                self.last_upload = Some(done);
            }
            if self.settings.effects == Effects::Auto {
                self.photon_map = Some(reuse_stats(self.frame_index, &stats, &self.lights));
            }
        }

        // Box D (graphics): photon volumes, upsampling, composite, glass, tonemap.
        self.prepare_debug_view()?;
        let d = gpu.record(QueueRole::Graphics, "box D", Some(timestamps.clone()))?;
        self.record_estimate_and_finish(&d.cmd(), &frame, slot)?;
        // The upload (which itself follows the readback); the readback too, for frames whose
        // trace stored nothing: box D takes the bounce map back from the transfer queue.
        let waits: Vec<Wait> = upload_done
            .into_iter()
            .chain(readback_done)
            .map(after)
            .collect();
        let d_done = self.submit(d, &waits)?;
        stats.accumulated_frames = accumulated + 1;
        stats.photon_sample = self.photons.as_ref().map_or(0, PhotonFrame::sample);
        stats.kernel = self.photons.as_ref().map(PhotonFrame::kernel);
        stats.tiles = self.photons.as_ref().and_then(PhotonFrame::tile_stats);

        self.last_frame_done = Some(d_done);
        self.slots[slot].pending = Some(PendingFrame {
            done: d_done,
            stats,
            start_ns,
            index: self.frame_index,
        });
        self.frame_index += 1;
        self.broken = false;
        drop(frame_span);
        Ok(())
    }

    /// How many frames the next frame's accumulation already holds (0: it starts one), and
    /// the photon sample and kernel scale for it: a still frame after the first of an
    /// accumulation gets a new, independent photon map (sample `last_sample + 1`) and kernels
    /// shrunk as probabilistic progressive photon mapping shrinks them
    /// ([`crate::photon::progressive::progressive_scale`]).
    fn next_accumulation(&mut self) -> anyhow::Result<u32> {
        if self.accumulate.is_none() {
            self.accumulated = 0;
            return Ok(0);
        }
        let frames = if self.still && self.plan.accumulate {
            self.accumulated
        } else {
            0
        };
        if frames > 0 {
            self.last_sample = self.last_sample.wrapping_add(1).max(1);
            self.photon_map = None;
        }
        if let Some(photons) = &mut self.photons {
            photons.set_sample(self.last_sample);
            photons.set_radius_scale(crate::photon::progressive::progressive_scale(frames));
        }
        self.accumulated = frames;
        self.place_area_samples(self.last_sample)?;
        Ok(frames)
    }

    /// Waits for every frame in flight and reads back the last one.
    pub fn finish(&mut self) -> anyhow::Result<FrameImage> {
        let (gpu_spans, stats) = self.drain()?;
        self.last_retired = Some((gpu_spans.clone(), stats.clone()));
        let gpu = self.gpu.clone();
        let hdr_bytes = gpu.read_image(&self.radiance)?;
        let ldr = gpu.read_image(&self.display)?;
        let hdr: Vec<f32> = bytemuck::pod_collect_to_vec(&hdr_bytes);
        gpu.collect_garbage();
        Ok(FrameImage {
            width: self.settings.width,
            height: self.settings.height,
            hdr,
            ldr,
            gpu_spans,
            stats,
        })
    }

    /// Waits for every frame in flight (oldest first) without reading images back; returns
    /// the last frame's GPU spans and stats, with the passes it ran and skipped and the lobes
    /// compiled out.
    pub fn drain(&mut self) -> anyhow::Result<(Vec<Span>, FrameStats)> {
        anyhow::ensure!(self.frame_index > 0, "no frame was submitted");
        let mut last = None;
        for k in (0..FRAMES_IN_FLIGHT as u64).rev() {
            if k < self.frame_index {
                let slot = ((self.frame_index - 1 - k) % FRAMES_IN_FLIGHT as u64) as usize;
                if let Some(retired) = self.retire_slot(slot)? {
                    last = Some(retired);
                }
            }
        }
        let (spans, mut stats) =
            last.ok_or_else(|| anyhow::anyhow!("the last frame was already retired"))?;
        stats.passes_run = spans.iter().map(|s| s.name.clone()).collect();
        stats.passes_run.dedup();
        stats.passes_skipped = self.skipped_passes(&stats);
        stats.variants_skipped = self.plan.variants_skipped(self.settings.bsdf_variant);
        stats.light_plan = self.plan.lights.clone();
        stats.subsample = self.settings.subsample_factor();
        Ok((spans, stats))
    }

    /// The passes `stats`' frame did not run, in frame order: the photon-map reuse's (already
    /// in `stats`), then the plan's (those that really did not run).
    fn skipped_passes(&self, stats: &FrameStats) -> Vec<SkippedPass> {
        let ran = |pass| {
            pass_ran(
                pass,
                stats.passes_run.iter().map(String::as_str),
                stats.cpu_trace_ms,
            )
        };
        self.plan
            .passes()
            .into_iter()
            .filter_map(|p| {
                if let Some(reused) = stats
                    .passes_skipped
                    .iter()
                    .find(|s| s.name == p.name.name())
                {
                    return Some(reused.clone());
                }
                if p.run && p.name == PassId::Denoise && !ran(p.name) {
                    // Planned, but an accumulation this long gets no levels (passes/denoise.rs).
                    return Some(SkippedPass {
                        name: p.name.name().to_string(),
                        reason: format!(
                            "--denoise {}: {} frames accumulated, the filter has stopped",
                            self.settings.denoise, stats.accumulated_frames
                        ),
                    });
                }
                (!p.run && !ran(p.name)).then(|| SkippedPass {
                    name: p.name.name().to_string(),
                    reason: p.reason,
                })
            })
            .collect()
    }

    /// Submits `rec`; in the serial schedule, also waits for it.
    fn submit(&self, rec: Recording, waits: &[Wait]) -> anyhow::Result<TimelinePoint> {
        let done = self.gpu.submit(rec, waits)?;
        if self.settings.schedule == Schedule::Serial {
            self.gpu.wait(done)?;
        }
        Ok(done)
    }

    /// Waits for the frame in `slot` (if any) and returns its GPU spans and stats.
    fn retire_slot(&mut self, slot: usize) -> anyhow::Result<Option<(Vec<Span>, FrameStats)>> {
        let Some(pending) = self.slots[slot].pending.take() else {
            return Ok(None);
        };
        {
            let _wait = timing::span_in("host wait", Some(pending.index));
            self.gpu.wait(pending.done)?;
        }
        let spans = self.slots[slot].timestamps.read()?;
        let mut stats = pending.stats;
        let end_ns = spans
            .iter()
            .map(|s| s.end_ns)
            .max()
            .unwrap_or(pending.start_ns);
        stats.frame_ms = end_ns.saturating_sub(pending.start_ns) as f64 * 1e-6;
        if let Some(check) = &self.value_check {
            stats.value_check = Some(check.read(slot)?);
        }
        Ok(Some((spans, stats)))
    }

    /// The host's part of a frame before any recording: light set-up and the frame constants.
    fn prepare(&self) -> FrameSetup {
        let camera_pos = self.camera.position().as_dvec3();
        let setup = LightSetup::active(
            &self.lights,
            &self.plan.direct_mask(),
            camera_pos,
            &self.scene.bounds,
            self.settings.shadow_resolution,
            SHADOW_FACE_MARGIN,
        );
        let view_proj = self.eye_view_proj();
        let uniforms = FrameUniforms {
            view_proj: view_proj.as_mat4(),
            inv_view_proj: view_proj.inverse().as_mat4(),
            camera_pos: camera_pos.as_vec3().extend(1.0),
            counts: UVec4::new(
                setup.lights.len() as u32,
                setup.views.len() as u32,
                self.settings.width,
                self.settings.height,
            ),
            params: Vec4::new(
                1.0 / self.settings.shadow_resolution.max(1) as f32,
                self.scene.bounds.extent().length(),
                0.0,
                0.0,
            ),
            viewer: Vec4::new(0.0, 0.0, 0.0, 1.0),
        };
        let shadow_draws: Vec<_> = setup
            .view_matrices
            .iter()
            .map(|&m| self.scene.draws(camera_pos, Some(m)))
            .collect();
        // Delta-material instances (glass, mirrors) are drawn by the translucent pass, so the
        // eye G-buffer holds what is behind them.
        let (delta_draws, eye_draws): (Vec<_>, Vec<_>) = self
            .scene
            .draws(camera_pos, None)
            .into_iter()
            .partition(|d| self.scene.is_delta(d));
        FrameSetup {
            camera_pos,
            setup,
            uniforms,
            shadow_draws,
            eye_draws,
            delta_draws,
        }
    }

    /// The frame's constants, written from the command stream so that frames in flight never
    /// share host-written memory.
    fn record_constants(&self, cmd: &Cmd, frame: &FrameSetup) {
        cmd.update_buffer(&self.frame_uniforms, 0, bytemuck::bytes_of(&frame.uniforms));
        cmd.update_buffer(
            &self.light_buffer,
            0,
            bytemuck::cast_slice(&frame.setup.lights),
        );
        cmd.update_buffer(
            &self.view_buffer,
            0,
            bytemuck::cast_slice(&frame.setup.views),
        );
        if let Some(translucent) = &self.translucent {
            let indirect = !matches!(self.debug_view, Some((DebugView::DirectOnly, _)));
            translucent.update(cmd, &frame.uniforms, frame.camera_pos, indirect);
        }
    }

    /// Box B: shadow maps, the eye G-buffer and direct light.
    fn record_eye_and_direct(&mut self, cmd: &Cmd, frame: &FrameSetup) {
        if !frame.shadow_draws.is_empty() {
            // No light lights the view (the plan): no shadow views, no shadow pass.
            self.shadow_maps.record(
                cmd,
                &self.scene,
                &frame.shadow_draws,
                &mut self.shadow_atlas,
            );
        }
        let view = View {
            index: 0,
            draws: &frame.eye_draws,
            layer: 0,
            extent: (self.settings.width, self.settings.height),
        };
        self.eye_gbuffer
            .record(cmd, &self.scene, &view, &mut self.gbuffer);
        let inputs = DirectInputs {
            frame: &self.frame_uniforms,
            materials: &self.scene.materials,
            lights: &self.light_buffer,
            shadow_views: &self.view_buffer,
            gbuffer: &self.gbuffer,
            shadow_atlas: &self.shadow_atlas,
        };
        self.direct.record(cmd, &inputs, &mut self.radiance);
    }

    /// Box D: photon volumes (+ upsampling and composite), glass and mirrors, tonemapping;
    /// with `check_values`, the value check of every HDR buffer, read back from frame slot
    /// `slot` when the frame retires.
    fn record_estimate_and_finish(
        &mut self,
        cmd: &Cmd,
        frame: &FrameSetup,
        slot: usize,
    ) -> anyhow::Result<()> {
        let composite = !matches!(self.debug_view, Some((DebugView::DirectOnly, _)));
        if let Some(check) = &mut self.value_check {
            check.begin(cmd, slot);
            check.image(cmd, Checked::Direct, &self.radiance)?;
        }
        if let Some(photons) = &mut self.photons {
            // Frames already in the mean this frame joins (0: it starts one, or stands alone).
            let accumulated = match (&self.accumulate, self.plan.accumulate) {
                (Some(_), true) => self.accumulated,
                _ => 0,
            };
            photons.record_estimate(
                cmd,
                (&self.frame_uniforms, &self.scene.materials, &self.gbuffer),
                (&mut self.radiance, slot, frame.uniforms.view_proj),
                (composite, accumulated, self.value_check.as_mut()),
            )?;
        }
        if let Some(translucent) = &mut self.translucent {
            let resources = TranslucentResources {
                frame: &self.frame_uniforms,
                lights: &self.light_buffer,
                shadow_views: &self.view_buffer,
                shadow_atlas: &self.shadow_atlas,
            };
            translucent.record(
                cmd,
                (&self.scene, &frame.eye_draws, &frame.delta_draws),
                &resources,
                &mut self.gbuffer.depth,
                &mut self.radiance,
            );
        }
        if let (Some(accumulate), true) = (&mut self.accumulate, self.plan.accumulate) {
            accumulate.record(cmd, &mut self.radiance, self.accumulated);
            self.accumulated += 1;
            self.still = true;
        }
        if let Some(check) = &mut self.value_check {
            check.image(cmd, Checked::Final, &self.radiance)?;
            check.end(cmd);
        }
        self.tonemap.record(
            cmd,
            &self.radiance,
            self.settings.tonemap,
            self.settings.exposure_ev,
            &mut self.display,
        );
        if let Some((_, Some(pass))) = &self.debug_view {
            let inputs = DebugInputs {
                frame: &self.frame_uniforms,
                gbuffer: &self.gbuffer,
                photons: self.photons.as_ref().map(PhotonFrame::debug_sources),
                tonemap: self.settings.tonemap,
                exposure_ev: self.settings.exposure_ev,
            };
            pass.record(cmd, &inputs, &mut self.display);
        }
        Ok(())
    }

    /// What the debug views read.
    fn debug_inputs(&self) -> DebugInputs<'_> {
        DebugInputs {
            frame: &self.frame_uniforms,
            gbuffer: &self.gbuffer,
            photons: self.photons.as_ref().map(PhotonFrame::debug_sources),
            tonemap: self.settings.tonemap,
            exposure_ev: self.settings.exposure_ev,
        }
    }

    /// Makes the debug view's pass if it has none or its inputs changed (a larger photon
    /// buffer); the old one retires once the frames using it are done.
    fn prepare_debug_view(&mut self) -> anyhow::Result<()> {
        let Some((view, pass)) = &self.debug_view else {
            return Ok(());
        };
        let (view, inputs) = (*view, self.debug_inputs());
        if pass.as_ref().is_some_and(|p| p.fits(view, &inputs)) {
            return Ok(());
        }
        let made = DebugViewPass::new(&self.gpu, view, &inputs, &self.display)?;
        self.debug_view = Some((view, Some(made)));
        Ok(())
    }

    /// Shows `view` (an intermediate buffer, `passes/debug_view.rs`) instead of the frame from
    /// the next frame on; `None`: the frame. Fails for a view of the photon part of the frame
    /// when this renderer has none (no indirect light).
    pub fn set_debug_view(&mut self, view: Option<DebugView>) -> anyhow::Result<()> {
        if let Some(v) = view {
            anyhow::ensure!(
                !v.needs_photons() || self.photons.is_some(),
                "the debug view {} needs indirect light, which this frame has none of ({})",
                v.label(),
                self.plan.indirect.reason
            );
        }
        if view != self.debug_view.as_ref().map(|(v, _)| *v) {
            self.debug_view = view.map(|v| (v, None));
            // The direct-only view leaves the estimate out of the radiance.
            self.restart_accumulation(false);
        }
        Ok(())
    }

    /// The debug view the frames show, if any.
    pub fn debug_view(&self) -> Option<DebugView> {
        self.debug_view.as_ref().map(|(v, _)| *v)
    }

    /// The newest finished frame's GPU spans and stats, without waiting (`None` until a frame
    /// has retired). Its `passes_run`/`passes_skipped` are filled in by [`Self::finish`] only.
    pub fn last_frame_times(&self) -> Option<&(Vec<Span>, FrameStats)> {
        self.last_retired.as_ref()
    }

    /// Changes the display transform from the next frame on (no new renderer needed).
    pub fn set_display_transform(&mut self, tonemap: Tonemap, exposure_ev: f32) {
        self.settings.tonemap = tonemap;
        self.settings.exposure_ev = exposure_ev;
    }

    /// The settings the frames use (after the plan's adjustments).
    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    pub fn gpu(&self) -> &Arc<Gpu> {
        &self.gpu
    }

    /// Image width in pixels.
    pub fn width(&self) -> u32 {
        self.settings.width
    }

    /// The scene's triangle count (for statistics).
    pub fn triangles(&self) -> usize {
        self.scene.triangles
    }

    /// The tonemapped image the last submitted frame draws (RGBA8, sRGB-encoded values).
    pub fn display(&self) -> &Image {
        &self.display
    }

    /// The photon part of the frame (`--method ispm` only).
    pub fn photons(&self) -> Option<&PhotonFrame> {
        self.photons.as_ref()
    }

    /// Reads back one of the eye G-buffer's colour images, by name, as raw texels.
    pub fn read_gbuffer(&self, which: &str) -> anyhow::Result<Vec<u8>> {
        let image = match which {
            "position" => &self.gbuffer.position,
            "normal" => &self.gbuffer.normal,
            "albedo" => &self.gbuffer.albedo,
            "material" => &self.gbuffer.material,
            other => anyhow::bail!("no G-buffer image named {other}"),
        };
        self.gpu.read_image(image)
    }
}
