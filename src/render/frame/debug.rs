//! The debug views (`--debug-view`, the viewer's `Tab`): what they read, made when chosen,
//! recorded after the tonemapping; and reading a G-buffer back (tests).

use super::Renderer;
use crate::passes::debug_view::{DebugInputs, DebugView, DebugViewPass};
use crate::render::photon_frame::PhotonFrame;

impl Renderer {
    /// What the debug views read.
    pub(super) fn debug_inputs(&self) -> DebugInputs<'_> {
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
    pub(super) fn prepare_debug_view(&mut self) -> anyhow::Result<()> {
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

    /// Reads back the direct pass's `lambert` image (RGBA32F: the Lambertian BRDF `c_L/π`, a = 1
    /// where the BSDF faces the eye), which exists at `--subsample N > 1` only. For the tests.
    pub fn read_lambert(&self) -> anyhow::Result<Option<Vec<f32>>> {
        let Some(image) = &self.lambert else {
            return Ok(None);
        };
        Ok(Some(bytemuck::pod_collect_to_vec(
            &self.gpu.read_image(image)?,
        )))
    }
}
