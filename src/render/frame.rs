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
//! [`Schedule::trace_beside_box_b`](crate::config::settings::Schedule::trace_beside_box_b)) (in scenes with glass or mirrors it then gathers the photons' light seen from
//! each environment probe's centre, `photon_frame/environment.rs`, and waits for the previous
//! frame's box D before it writes those cubes' staging buffers); then it issues the photon map's
//! upload and box D, which waits for it. Every
//! cross-queue dependency is a wait on a queue's timeline; the bounce map and the photon buffer
//! change queue-family ownership with release/acquire barriers where the transfer queue is a
//! family of its own (`Cmd::release_buffer`). Per-frame constants go through the command stream
//! (`Cmd::update_buffer`), so [`FRAMES_IN_FLIGHT`](crate::config::settings::FRAMES_IN_FLIGHT) frames can be in flight without the host
//! writing memory an earlier frame still reads; a frame slot's timestamps are read when the
//! slot comes round again (or in [`Renderer::finish`]). [`Schedule::Serial`](crate::config::settings::Schedule::Serial) waits after every
//! submission: the same work strictly in order, the baseline `ispm bench` compares against.
//!
//! The effects plan (`plan/mod.rs`, issue #9) decides which of these steps exist, which lights they
//! cover and which BSDF lobes their shaders compile; while no light changes and no instance
//! moves, frames after the first reuse its photon map (no light G-buffers, bounce map, readback,
//! trace or upload), and a camera move ([`Renderer::set_camera`]) keeps it: the photon map does
//! not depend on the camera (`photon_frame.rs`); when a light changes, only the lights whose
//! planned views changed are re-traced, the others' photons kept (`photon_frame/retrace.rs`).
//! `docs/effects.md`: the rules and the measured
//! equivalence with `--effects all`. Moving instances and posing an animated scene:
//! `frame/motion.rs`.

use crate::config::settings::Tonemap;
use crate::gpu::scene::GpuScene;
use crate::gpu::{vk, Buffer, Gpu, Image, Span, TimelinePoint, Timestamps, Wait};
use crate::layout::FrameUniforms;
use crate::passes::accumulate::AccumulatePass;
use crate::passes::debug_view::{DebugView, DebugViewPass};
use crate::passes::direct::DirectPass;
use crate::passes::eye_gbuffer::{EyeGBufferPass, GBuffer};
use crate::passes::shadow_map::ShadowMapPass;
use crate::passes::tonemap::TonemapPass;
use crate::passes::value_check::Checked;
use crate::passes::value_check::ValueCheckPass;
use crate::plan::lighting::LightSetup;
use crate::plan::{EffectsPlan, SceneAnalysis};
use crate::render::photon_frame::{PhotonFrame, PhotonTargets};
use crate::render::translucent_frame::TranslucentFrame;
use crate::scene::{Camera, Light, Scene};
use glam::DMat4;
use std::sync::Arc;

mod debug;
mod emission;
mod motion;
mod new;
mod record;
mod submit;

/// Texels by which shadow cube faces overlap (lookup offset ≤ 1.5 + PCF 1 + bilinear 0.5).
const SHADOW_FACE_MARGIN: u32 = 3;

use crate::config::settings::RenderSettings;
use crate::render::stats::{skipped, REUSE_SKIPS};
use crate::render::stats::{FrameImage, FrameStats, ReusedLight};

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
    /// At `--subsample N > 1` with ISPM: the pixels' Lambertian BRDF `c_L/π`, which the direct
    /// pass writes and the upsample reads (`passes/direct.rs`).
    lambert: Option<Image>,
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
    shadow_draws: Vec<Vec<crate::gpu::scene::Draw>>,
    eye_draws: Vec<crate::gpu::scene::Draw>,
    delta_draws: Vec<crate::gpu::scene::Draw>,
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
    ///   views, lights, instances, the environment probes' centres), made in f64 each frame;
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
    /// stats list the photon passes as skipped, the map reused); the environment cube maps,
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
            let photons = PhotonFrame::new(
                &self.gpu,
                &source,
                &self.scene,
                (&self.settings, &plan),
                &PhotonTargets {
                    frame: &self.frame_uniforms,
                    gbuffer: &self.gbuffer,
                    radiance: &self.radiance,
                    lambert: self.lambert.as_ref(),
                },
            )?;
            // Its images, planned as it was made (`gpu/image.rs`).
            self.gpu.make_planned()?;
            self.photons = Some(photons);
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

    /// The HDR radiance the frame accumulates into (RGBA32F).
    pub fn radiance(&self) -> &Image {
        &self.radiance
    }

    /// The tonemapped image the last submitted frame draws (RGBA8, sRGB-encoded values).
    pub fn display(&self) -> &Image {
        &self.display
    }

    /// The photon part of the frame (`--method ispm` only).
    pub fn photons(&self) -> Option<&PhotonFrame> {
        self.photons.as_ref()
    }
}
