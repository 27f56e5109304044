//! The frame, as an ordered script of passes.
//!
//! ```text
//!  photons (--method ispm):
//!   light_gbuffers ──► bounce_map ──► readback ══► cpu_trace (all cores) ══► upload
//!  every method:
//!   shadow_maps ──► eye_gbuffer ──► direct ──► photon_volumes ──► composite ──►
//!                   (opaque only)              (ispm only)        (ispm only)
//!     environment ──► translucent ──► tonemap
//!     (cached cube)   (glass, mirrors; scenes with delta materials only)
//! ```
//!
//! The photon steps are one command buffer; the host waits for it, traces, and the rest of the
//! frame follows in a second one, everything on the graphics queue and timed per pass. This is
//! the serial order; the overlapped schedule of the paper's Figure 3 reorders the same steps.

use crate::gpu::{
    vk, Buffer, Gpu, Image, ImageDesc, MemoryLocation, QueueRole, Span, Timestamps, ViewKind,
};
use crate::gpu_scene::GpuScene;
use crate::layout::FrameUniforms;
use crate::lighting::LightSetup;
use crate::passes::direct::{DirectInputs, DirectPass};
use crate::passes::eye_gbuffer::{EyeGBufferPass, GBuffer, View};
use crate::passes::shadow_map::{self, ShadowMapPass};
use crate::passes::tonemap::{self, Tonemap, TonemapPass};
use crate::photon::bsdf::BsdfVariant;
use crate::photon_frame::PhotonFrame;
use crate::plan::Effects;
use crate::scene::{Camera, Light, Scene};
use crate::timing;
use crate::translucent_frame::{TranslucentFrame, TranslucentResources};
use glam::{DMat4, UVec4, Vec4};
use std::sync::Arc;

/// Texels by which shadow cube faces overlap (normal offset 1.5 + PCF 1 + bilinear 0.5).
const SHADOW_FACE_MARGIN: u32 = 3;

/// How the frame computes light.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Image Space Photon Mapping: direct light plus photon-mapped indirect light.
    #[default]
    Ispm,
    /// Shadow-mapped deferred direct light only.
    Direct,
}

/// What to render and how.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub method: Method,
    /// Photons emitted from all lights together (split by power).
    pub photons: usize,
    /// Most scattering events a photon may take.
    pub bounces: u32,
    /// Largest kernel radius in metres (`None`: relative to the scene and photon count).
    pub radius: Option<f32>,
    /// Seed of every random choice (frame-coherent: same seed, same photons).
    pub seed: u32,
    pub width: u32,
    pub height: u32,
    /// Shadow-map resolution per light view (texels per side).
    pub shadow_resolution: u32,
    pub tonemap: Tonemap,
    /// Exposure in stops: the radiance is multiplied by 2^EV before tonemapping.
    pub exposure_ev: f32,
    /// Photon volumes at 1/N resolution, upsampled (1: full resolution, no upsampling).
    pub subsample: u32,
    /// `Auto`: the effects plan (`plan::EffectsPlan`) may skip what the scene does not need;
    /// `All`: every pass and shader variant runs (`--effects all`, for comparison).
    pub effects: Effects,
    /// The über-BSDF lobes compiled into every shader that evaluates it (default: all).
    /// `EffectsPlan::bsdf_variant` is the smallest one a scene renders exactly with.
    pub bsdf_variant: BsdfVariant,
    /// Smallest share of each light's photons spent on its caustic views, the windows around
    /// the mirrors and glass it lights (`ispm::CAUSTIC_SHARE`; 0: no caustic views).
    pub caustic_share: f32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            method: Method::Ispm,
            photons: 100_000,
            bounces: 8,
            radius: None,
            seed: 0,
            width: 640,
            height: 480,
            shadow_resolution: 1024,
            tonemap: Tonemap::default(),
            exposure_ev: 0.0,
            subsample: 1,
            effects: Effects::Auto,
            bsdf_variant: BsdfVariant::ALL,
            caustic_share: crate::ispm::CAUSTIC_SHARE,
        }
    }
}

/// A rendered frame read back to the host.
#[derive(Clone, Debug)]
pub struct FrameImage {
    pub width: u32,
    pub height: u32,
    /// Linear HDR radiance, RGBA f32, top row first.
    pub hdr: Vec<f32>,
    /// Tonemapped sRGB, RGBA8, top row first.
    pub ldr: Vec<u8>,
    /// GPU time of each pass.
    pub gpu_spans: Vec<Span>,
    pub stats: FrameStats,
}

/// The paper's Table 2 numbers for one frame.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct FrameStats {
    pub emitted_photons: usize,
    /// Photons that survived the first (GPU) bounce.
    pub bounce_map_photons: usize,
    pub stored_photons: usize,
    /// Photons alive after each bounce (the paper's Figure 10).
    pub attrition: Vec<u64>,
    pub cpu_trace_ms: f64,
    /// Host time from the frame's start to the end of its GPU work.
    pub frame_ms: f64,
    pub passes_run: Vec<String>,
    /// The subsample factor the frame used (after clamping to the image size).
    pub subsample: u32,
}

/// Renders frames of one scene at one size.
pub struct Renderer {
    gpu: Arc<Gpu>,
    settings: RenderSettings,
    camera: Camera,
    lights: Vec<Light>,
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
    photons: Option<PhotonFrame>,
    /// Glass and mirrors (scenes with delta materials only).
    translucent: Option<TranslucentFrame>,
    timestamps: Arc<Timestamps>,
    /// Index of the next frame (the `frame` of its spans).
    frame_index: u64,
}

fn host_buffer(
    gpu: &Arc<Gpu>,
    name: &str,
    size: usize,
    usage: vk::BufferUsageFlags,
) -> anyhow::Result<Buffer> {
    Ok(Buffer::new(
        gpu,
        name,
        size as u64,
        usage,
        MemoryLocation::CpuToGpu,
    )?)
}

impl Renderer {
    pub fn new(gpu: &Arc<Gpu>, scene: &Scene, settings: RenderSettings) -> anyhow::Result<Self> {
        anyhow::ensure!(
            settings.width > 0 && settings.height > 0,
            "image size {}x{} is empty",
            settings.width,
            settings.height
        );
        let gpu_scene = GpuScene::new(gpu, scene)?;
        let setup = LightSetup::new(
            &scene.lights,
            scene.camera.position().as_dvec3(),
            &gpu_scene.bounds,
            settings.shadow_resolution,
            SHADOW_FACE_MARGIN,
        );
        let frame_uniforms = host_buffer(
            gpu,
            "frame.uniforms",
            size_of::<FrameUniforms>(),
            vk::BufferUsageFlags::UNIFORM_BUFFER,
        )?;
        let light_buffer = host_buffer(
            gpu,
            "frame.lights",
            size_of::<crate::layout::GpuLight>() * setup.lights.len().max(1),
            vk::BufferUsageFlags::STORAGE_BUFFER,
        )?;
        let view_buffer = host_buffer(
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
                usage: vk::ImageUsageFlags::STORAGE
                    | vk::ImageUsageFlags::COLOR_ATTACHMENT
                    | vk::ImageUsageFlags::SAMPLED
                    | vk::ImageUsageFlags::TRANSFER_SRC,
                view: ViewKind::D2,
            },
        )?;
        let display = tonemap::output(gpu, settings.width, settings.height)?;
        let shadow_maps = ShadowMapPass::new(gpu)?;
        let eye_gbuffer =
            EyeGBufferPass::new(gpu, "eye_gbuffer", &gpu_scene, &[&frame_uniforms], true)?;
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
        let photons = match settings.method {
            Method::Ispm => Some(PhotonFrame::new(
                gpu,
                scene,
                &gpu_scene,
                &settings,
                &frame_uniforms,
                &gbuffer,
                &radiance,
            )?),
            Method::Direct => None,
        };
        let translucent = TranslucentFrame::new(
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
        )?;
        let timestamps = Timestamps::new(gpu, "frame.timestamps", 64)?;
        Ok(Self {
            gpu: gpu.clone(),
            settings,
            camera: scene.camera,
            lights: scene.lights.clone(),
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
            photons,
            translucent,
            timestamps,
            frame_index: 0,
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

    /// Renders one frame, waits for it, and reads the images back.
    pub fn render(&mut self) -> anyhow::Result<FrameImage> {
        let frame_span = timing::frame(self.frame_index);
        let gpu = self.gpu.clone();
        let camera_pos = self.camera.position().as_dvec3();
        let setup = LightSetup::new(
            &self.lights,
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
        self.frame_uniforms
            .write(0, bytemuck::bytes_of(&uniforms))?;
        self.light_buffer
            .write(0, bytemuck::cast_slice(&setup.lights))?;
        self.view_buffer
            .write(0, bytemuck::cast_slice(&setup.views))?;
        if let Some(translucent) = &self.translucent {
            translucent.update(&uniforms, camera_pos)?;
        }

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

        self.timestamps.reset(self.frame_index);
        let mut stats = FrameStats::default();
        if let Some(photons) = &mut self.photons {
            stats = photons.emit_and_trace(&self.scene, &self.timestamps)?;
        }
        let rec = gpu.record(QueueRole::Graphics, "frame", Some(self.timestamps.clone()))?;
        {
            let cmd = rec.cmd();
            let _frame = cmd.scope("frame");
            if let Some(photons) = &self.photons {
                photons.record_upload(&cmd);
            }
            self.shadow_maps
                .record(&cmd, &self.scene, &shadow_draws, &mut self.shadow_atlas);
            let view = View {
                index: 0,
                draws: &eye_draws,
                layer: 0,
                extent: (self.settings.width, self.settings.height),
            };
            self.eye_gbuffer
                .record(&cmd, &self.scene, &view, &mut self.gbuffer);
            let inputs = DirectInputs {
                frame: &self.frame_uniforms,
                materials: &self.scene.materials,
                lights: &self.light_buffer,
                shadow_views: &self.view_buffer,
                gbuffer: &self.gbuffer,
                shadow_atlas: &self.shadow_atlas,
            };
            self.direct.record(&cmd, &inputs, &mut self.radiance);
            if let Some(photons) = &mut self.photons {
                photons.record_estimate(
                    &cmd,
                    &self.frame_uniforms,
                    &self.scene.materials,
                    &self.gbuffer,
                    &mut self.radiance,
                );
            }
            if let Some(translucent) = &mut self.translucent {
                translucent.record(
                    &cmd,
                    &self.scene,
                    (&eye_draws, &delta_draws),
                    &self.shadow_atlas,
                    &mut self.gbuffer.depth,
                    &mut self.radiance,
                );
            }
            self.tonemap.record(
                &cmd,
                &self.radiance,
                self.settings.tonemap,
                self.settings.exposure_ev,
                &mut self.display,
            );
        }
        let done = gpu.submit(rec, &[])?;
        timing::timed("host wait", || gpu.wait(done))?;
        stats.frame_ms = frame_span.finish();
        self.frame_index += 1;
        let gpu_spans = self.timestamps.read()?;
        stats.passes_run = gpu_spans.iter().map(|s| s.name.clone()).collect();
        stats.passes_run.dedup();
        stats.subsample = crate::photon_frame::subsample_factor(&self.settings);
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
