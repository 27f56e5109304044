//! The photon part of an ISPM frame: light G-buffers → bounce map → readback → CPU trace →
//! upload → photon volumes (→ upsample at `--subsample N > 1`) → composite. Owns the buffers
//! and passes those steps use; `frame.rs` calls its three steps in order.

use crate::frame::{FrameStats, RenderSettings};
use crate::gpu::{
    vk, Access, Buffer, Cmd, Gpu, Image, MemoryLocation, QueueRole, Timestamps, ViewKind,
};
use crate::gpu_scene::GpuScene;
use crate::ispm::BouncePlan;
use crate::passes::bounce_map::{BounceMapIo, BounceMapPass};
use crate::passes::composite::CompositePass;
use crate::passes::eye_gbuffer::GBuffer;
use crate::passes::light_gbuffer::LightGBufferPass;
use crate::passes::photon_volumes::{self, PhotonVolumeInputs, PhotonVolumesPass};
use crate::passes::upsample::{self, UpsampleInputs, UpsamplePass};
use crate::photon::bvh::SceneBvh;
use crate::photon::kernel::KernelSettings;
use crate::photon::trace::{trace_photons, TraceSettings};
use crate::photon::types::{BounceMapPhoton, Photon};
use crate::scene::Scene;
use crate::timing;
use std::sync::Arc;

pub struct PhotonFrame {
    gpu: Arc<Gpu>,
    scene: Scene,
    bvh: SceneBvh,
    plan: BouncePlan,
    trace: TraceSettings,
    kernel: KernelSettings,
    light_gbuffer: GBuffer,
    light_pass: LightGBufferPass,
    views: Buffer,
    bounce_map: Buffer,
    readback: Buffer,
    bounce_pass: BounceMapPass,
    staging: Buffer,
    photons: Buffer,
    count: u32,
    rebind: bool,
    photon_pass: PhotonVolumesPass,
    /// `--subsample N > 1`: the low-resolution targets and the pass that upsamples them.
    subsampled: Option<Subsampled>,
    indirect: Image,
    composite: CompositePass,
    /// The last frame's bounce map and photon map (camera-relative positions), as drawn.
    last_bounce_map: Vec<BounceMapPhoton>,
    last_photons: Vec<Photon>,
}

struct Subsampled {
    low: [Image; 2],
    upsample: UpsamplePass,
}

/// The subsample factor a frame uses: at least 1, at most the image's larger side (beyond it
/// the low-resolution image stays 1×1).
pub fn subsample_factor(settings: &RenderSettings) -> u32 {
    settings
        .subsample
        .clamp(1, settings.width.max(settings.height).max(1))
}

fn photon_buffers(gpu: &Arc<Gpu>, capacity: usize) -> anyhow::Result<(Buffer, Buffer)> {
    let bytes = (capacity.max(1) * size_of::<Photon>()) as u64;
    let staging = Buffer::new(
        gpu,
        "photon_map.staging",
        bytes,
        vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::CpuToGpu,
    )?;
    let device = Buffer::new(
        gpu,
        "photon_map",
        bytes,
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
        MemoryLocation::GpuOnly,
    )?;
    Ok((staging, device))
}

impl PhotonFrame {
    pub fn new(
        gpu: &Arc<Gpu>,
        scene: &Scene,
        gpu_scene: &GpuScene,
        settings: &RenderSettings,
        frame: &Buffer,
        gbuffer: &GBuffer,
        radiance: &Image,
    ) -> anyhow::Result<Self> {
        let camera = scene.camera.position().as_dvec3();
        let plan = BouncePlan::with_caustic_share(
            scene,
            &vec![true; scene.lights.len()],
            camera,
            &gpu_scene.bounds,
            settings.photons,
            settings.caustic_share,
        );
        let views = plan.views.len().max(1);
        let light_gbuffer = GBuffer::new(
            gpu,
            "light_gbuffer",
            plan.max_extent.0.max(1),
            plan.max_extent.1.max(1),
            views as u32,
            ViewKind::D2Array,
        )?;
        let light_pass = LightGBufferPass::new(gpu, gpu_scene, views)?;
        let view_buffer = Buffer::new(
            gpu,
            "bounce_map.views",
            (views * size_of::<crate::layout::BounceView>()) as u64,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::CpuToGpu,
        )?;
        let bounce_bytes = (plan.texels.max(1) * size_of::<BounceMapPhoton>()) as u64;
        let bounce_map = Buffer::new(
            gpu,
            "bounce_map",
            bounce_bytes,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?;
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
                bounce_map: &bounce_map,
            },
            settings.bsdf_variant,
        )?;
        let (staging, photons) = photon_buffers(gpu, 1)?;
        let subsample = subsample_factor(settings);
        let photon_pass = PhotonVolumesPass::new(
            gpu,
            &PhotonVolumeInputs {
                frame,
                photons: &photons,
                materials: &gpu_scene.materials,
                gbuffer,
            },
            subsample,
            settings.bsdf_variant,
        )?;
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
            let upsample =
                UpsamplePass::new(gpu, &inputs, &indirect, subsample, settings.bsdf_variant)?;
            (indirect, Some(Subsampled { low, upsample }))
        };
        let composite = CompositePass::new(gpu, &indirect, radiance)?;
        Ok(Self {
            gpu: gpu.clone(),
            scene: scene.clone(),
            bvh: SceneBvh::new(scene),
            trace: TraceSettings {
                max_bounces: settings.bounces.max(1),
                seed: settings.seed,
            },
            // The footprint floor of the image the estimate is made at (the low one when
            // subsampling).
            kernel: KernelSettings::scene_relative(
                &gpu_scene.bounds,
                settings.photons,
                settings.radius,
            )
            .for_view(
                scene.camera.yfov,
                upsample::low_size(radiance.width, radiance.height, subsample).1,
            ),
            plan,
            light_gbuffer,
            light_pass,
            views: view_buffer,
            bounce_map,
            readback,
            bounce_pass,
            staging,
            photons,
            count: 0,
            rebind: false,
            photon_pass,
            subsampled,
            indirect,
            composite,
            last_bounce_map: Vec::new(),
            last_photons: Vec::new(),
        })
    }

    /// Light G-buffers and bounce map on the GPU, then the readback and the CPU trace; leaves
    /// the photon map in the staging buffer for [`PhotonFrame::record_upload`].
    pub fn emit_and_trace(
        &mut self,
        scene: &GpuScene,
        timestamps: &Arc<Timestamps>,
    ) -> anyhow::Result<FrameStats> {
        let plan = &self.plan;
        let mut stats = FrameStats {
            emitted_photons: plan.texels,
            ..Default::default()
        };
        if plan.texels == 0 {
            self.count = 0;
            return Ok(stats);
        }
        self.light_pass.update(&plan.uniforms)?;
        self.views.write(0, bytemuck::cast_slice(&plan.views))?;
        // Camera-relative models; each view's uniforms hold its light clip transform.
        let relative = scene.draws(plan.camera, None);
        let draws = vec![relative; plan.views.len()];
        let rec = self.gpu.record(
            QueueRole::Graphics,
            "photon_emission",
            Some(timestamps.clone()),
        )?;
        {
            let cmd = rec.cmd();
            {
                let _scope = cmd.scope("light_gbuffers");
                self.light_pass
                    .record(&cmd, scene, &draws, &plan.extents, &mut self.light_gbuffer);
            }
            let io = BounceMapIo {
                materials: &scene.materials,
                views: &self.views,
                light_gbuffer: &self.light_gbuffer,
                bounce_map: &self.bounce_map,
            };
            self.bounce_pass.record(
                &cmd,
                &io,
                plan.max_extent,
                plan.views.len() as u32,
                self.trace.seed,
            );
            let _scope = cmd.scope("readback");
            cmd.copy_buffer(&self.bounce_map, &self.readback);
            cmd.transition_buffer(&self.readback, Access::HostRead);
        }
        let done = self.gpu.submit(rec, &[])?;
        timing::timed("readback wait", || self.gpu.wait(done))?;

        let bytes = self.readback.read()?;
        let records = plan.texels * size_of::<BounceMapPhoton>();
        let bounce_map: Vec<BounceMapPhoton> = bytemuck::pod_collect_to_vec(&bytes[..records]);
        let trace_span = timing::span("cpu_trace");
        let starts = plan.photon_starts(&bounce_map);
        let map = trace_photons(&self.scene, &self.bvh, &starts, &self.trace);
        stats.cpu_trace_ms = trace_span.finish();
        stats.bounce_map_photons = starts.len();
        stats.stored_photons = map.photons.len();
        stats.attrition = map.attrition;

        // Camera-relative positions, subtracted in f64 (see DESIGN: precision far from origin).
        let relative: Vec<Photon> = map
            .photons
            .iter()
            .map(|p| Photon {
                position: (p.position.as_dvec3() - plan.camera).as_vec3(),
                ..*p
            })
            .collect();
        if relative.len() * size_of::<Photon>() > self.photons.size as usize {
            let (staging, photons) = photon_buffers(&self.gpu, relative.len().next_power_of_two())?;
            self.staging = staging;
            self.photons = photons;
            self.rebind = true;
        }
        timing::timed("upload write", || {
            self.staging.write(0, bytemuck::cast_slice(&relative))
        })?;
        self.count = relative.len() as u32;
        self.last_bounce_map = bounce_map;
        self.last_photons = relative;
        Ok(stats)
    }

    /// Copies the photon map to the GPU.
    pub fn record_upload(&self, cmd: &Cmd) {
        if self.count == 0 {
            return;
        }
        let _scope = cmd.scope("upload");
        cmd.copy_buffer(&self.staging, &self.photons);
    }

    /// Photon volumes into the indirect buffer (at 1/N resolution and upsampled, at
    /// `--subsample N > 1`), then radiance += indirect.
    pub fn record_estimate(
        &mut self,
        cmd: &Cmd,
        frame: &Buffer,
        materials: &Buffer,
        gbuffer: &GBuffer,
        radiance: &mut Image,
    ) {
        let inputs = PhotonVolumeInputs {
            frame,
            photons: &self.photons,
            materials,
            gbuffer,
        };
        if self.rebind {
            self.photon_pass.rebind(&inputs);
            self.rebind = false;
        }
        match &mut self.subsampled {
            None => self.photon_pass.record(
                cmd,
                &inputs,
                self.count,
                &self.kernel,
                std::slice::from_mut(&mut self.indirect),
            ),
            Some(sub) => {
                self.photon_pass
                    .record(cmd, &inputs, self.count, &self.kernel, &mut sub.low);
                let inputs = UpsampleInputs {
                    materials,
                    gbuffer,
                    low: &sub.low,
                };
                sub.upsample.record(cmd, &inputs, &mut self.indirect);
            }
        }
        self.composite.record(cmd, &self.indirect, radiance);
    }

    /// The light views the bounce map is made of.
    pub fn plan(&self) -> &BouncePlan {
        &self.plan
    }

    /// The last frame's bounce map, one record per light-G-buffer texel.
    pub fn bounce_map(&self) -> &[BounceMapPhoton] {
        &self.last_bounce_map
    }

    /// The last frame's photon map as drawn (positions relative to the camera).
    pub fn photon_map(&self) -> &[Photon] {
        &self.last_photons
    }

    /// The kernel radius clamp the photon volumes use.
    pub fn kernel(&self) -> KernelSettings {
        self.kernel
    }

    /// Reads back the indirect radiance (RGBA f32; alpha = volumes per pixel).
    pub fn read_indirect(&self) -> anyhow::Result<Vec<f32>> {
        Ok(bytemuck::pod_collect_to_vec(
            &self.gpu.read_image(&self.indirect)?,
        ))
    }
}
