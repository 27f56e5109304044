//! What boxes A, B and D record: the per-frame constants, shadow maps, eye G-buffer and direct
//! light, then the photon estimate, glass, accumulation, tonemapping and debug view, in the
//! order of the paper's Figure 3.

use super::{FrameSetup, Renderer, SHADOW_FACE_MARGIN};
use crate::gpu::Cmd;
use crate::layout::FrameUniforms;
use crate::passes::debug_view::{DebugInputs, DebugView};
use crate::passes::direct::DirectInputs;
use crate::passes::eye_gbuffer::View;
use crate::passes::value_check::Checked;
use crate::plan::lighting::LightSetup;
use crate::render::photon_frame::PhotonFrame;
use crate::render::translucent_frame::TranslucentResources;
use glam::{UVec4, Vec4};

impl Renderer {
    /// The host's part of a frame before any recording: light set-up and the frame constants.
    pub(super) fn prepare(&self) -> FrameSetup {
        let camera_pos = self.camera.position().as_dvec3();
        let view_proj = self.eye_view_proj();
        let setup = LightSetup::active(
            &self.lights,
            &self.plan.direct_mask(),
            (camera_pos, Some(&view_proj)),
            &self.scene.bounds,
            self.settings.shadow_resolution,
            SHADOW_FACE_MARGIN,
        );
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
    pub(super) fn record_constants(&self, cmd: &Cmd, frame: &FrameSetup) {
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
    pub(super) fn record_eye_and_direct(&mut self, cmd: &Cmd, frame: &FrameSetup) {
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
        self.direct
            .record(cmd, &inputs, (&mut self.radiance, self.lambert.as_mut()));
    }

    /// Box D: photon volumes (+ upsampling and composite), glass and mirrors, tonemapping;
    /// with `check_values`, the value check of every HDR buffer, read back from frame slot
    /// `slot` when the frame retires.
    pub(super) fn record_estimate_and_finish(
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
                self.lambert.as_ref(),
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
}
