//! The estimate half of the photon part of a frame: the photon volumes drawn for the current
//! eye (`set_view`: the eye-relative offset and the kernel's footprint floor), upsampled at
//! `--subsample N > 1`, composited, and what the debug views read of it.

use super::PhotonFrame;
use crate::gpu::{Access, Buffer, Cmd, Image, QueueRole};
use crate::passes::debug_view::PhotonSources;
use crate::passes::eye_gbuffer::GBuffer;
use crate::passes::photon_volumes::PhotonVolumeInputs;
use crate::passes::upsample::UpsampleInputs;
use crate::photon::kernel::KernelSettings;

impl PhotonFrame {
    /// Draws the photon volumes for `camera` from the next recorded estimate on: its position
    /// (the offset added to the photons) and its field of view (the kernel's footprint floor).
    /// The photon map itself does not depend on the camera and stays valid.
    pub fn set_view(&mut self, camera: &crate::scene::Camera) {
        self.eye = camera.position().as_dvec3();
        self.kernel = self
            .kernel_clamp
            .for_view(camera.yfov, self.estimate_height);
    }

    /// What the photon volumes add to each stored position to make it eye-relative:
    /// `origin − eye`, subtracted in f64 and rounded once.
    pub(super) fn eye_offset(&self) -> glam::Vec3 {
        (self.plan.origin - self.eye).as_vec3()
    }

    /// Photon volumes into the indirect buffer (at 1/N resolution and upsampled, at
    /// `--subsample N > 1`), then radiance += indirect. Takes the photon buffer over from the
    /// transfer queue after an upload (a no-op in a frame that reuses the photon map) and keeps
    /// it until the next [`Self::record_emission`]. Without `composite` (the direct-only debug
    /// view) the estimate is made but not added.
    pub fn record_estimate(
        &mut self,
        cmd: &Cmd,
        (frame, materials, gbuffer): (&Buffer, &Buffer, &GBuffer),
        radiance: &mut Image,
        composite: bool,
    ) {
        if self.count > 0 {
            cmd.acquire_buffer(
                &self.photons,
                QueueRole::Transfer,
                Access::GraphicsStorageRead,
            );
            self.photons_on_graphics = true;
        }
        if !self.batches.is_empty() {
            // Back from the readback, for the next frame's bounce map.
            cmd.acquire_buffer(
                &self.bounce_map,
                QueueRole::Transfer,
                Access::ComputeStorageWrite,
            );
        }
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
        let volumes = (self.count, &self.kernel, self.eye_offset());
        match &mut self.subsampled {
            None => self.photon_pass.record(
                cmd,
                &inputs,
                volumes,
                std::slice::from_mut(&mut self.indirect),
            ),
            Some(sub) => {
                self.photon_pass.record(cmd, &inputs, volumes, &mut sub.low);
                let inputs = UpsampleInputs {
                    materials,
                    gbuffer,
                    low: &sub.low,
                };
                sub.upsample.record(cmd, &inputs, &mut self.indirect);
            }
        }
        if composite {
            self.composite.record(cmd, &self.indirect, radiance);
        }
    }

    /// What the debug views read of the photon part of the frame (`passes/debug_view.rs`).
    pub fn debug_sources(&self) -> PhotonSources<'_> {
        let lum = |c: glam::Vec3| c.dot(glam::Vec3::new(0.2126, 0.7152, 0.0722));
        let first = self.plan.views.first().map(|v| (v.texels.x, v.texels.y));
        let (offset, records) = self.plan.views.first().map_or((0, 0), |v| {
            (v.texels.z as usize, (v.texels.x * v.texels.y) as usize)
        });
        let bounce_peak = self
            .traced
            .bounce_map()
            .iter()
            .skip(offset)
            .take(records)
            .map(|p| lum(p.power))
            .fold(0.0, f32::max);
        let photon_peak = self
            .traced
            .photons()
            .take(self.count as usize)
            .map(|p| lum(p.power))
            .fold(0.0, f32::max);
        PhotonSources {
            light_gbuffer: &self.light_gbuffer,
            first_view_extent: first.unwrap_or((0, 0)),
            views: &self.views,
            bounce_map: &self.bounce_map,
            bounce_peak,
            photons: &self.photons,
            count: self.count,
            photon_peak,
            offset: self.eye_offset(),
            indirect: &self.indirect,
        }
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
