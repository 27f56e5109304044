//! Light G-buffers: the scene rasterised from every light view (spot: one frustum, point: six
//! cube faces, directional: an orthographic box; and the caustic views, windows of those around
//! the delta instances, `plan/bounce_plan.rs`), each into one layer of an array G-buffer, at the resolution
//! the light's share of the photon budget asks for (drawn into the layer's top-left texels).
//! Texel (x, y) of a view is where the photon through that texel first hits the scene: the
//! bounce map starts from it.

use super::eye_gbuffer::{GBuffer, GBufferPass, View};
use crate::gpu::scene::{Draw, GpuScene};
use crate::gpu::{vk, Buffer, Cmd, Gpu};
use crate::layout::FrameUniforms;
use crate::timing::pass_id::PassId;
use std::sync::Arc;

pub struct LightGBufferPass {
    raster: GBufferPass,
    /// One `FrameUniforms` per light view.
    frames: Vec<Buffer>,
}

impl LightGBufferPass {
    pub fn new(gpu: &Arc<Gpu>, scene: &GpuScene, views: usize) -> anyhow::Result<Self> {
        let frames = (0..views.max(1))
            .map(|i| {
                Buffer::constants(
                    gpu,
                    &format!("light_gbuffers.view[{i}]"),
                    size_of::<FrameUniforms>() as u64,
                    vk::BufferUsageFlags::UNIFORM_BUFFER,
                )
            })
            .collect::<Result<Vec<_>, _>>()?;
        let refs: Vec<&Buffer> = frames.iter().collect();
        // The light views reverse depth as the eye's does (`plan/lighting.rs`).
        let raster = GBufferPass::new(gpu, PassId::LightGbuffer, scene, &refs)?;
        Ok(Self { raster, frames })
    }

    /// Records the uniforms of every view into the command stream (before [`Self::record`]).
    pub fn update(&self, cmd: &Cmd, uniforms: &[FrameUniforms]) {
        for (buffer, u) in self.frames.iter().zip(uniforms) {
            cmd.update_buffer(buffer, 0, bytemuck::bytes_of(u));
        }
    }

    /// Draws view i (`draws[i]` into the top-left `extents[i]` texels) into layer i of
    /// `gbuffer`; empty views (lights without photons) are skipped.
    pub fn record(
        &self,
        cmd: &Cmd,
        scene: &GpuScene,
        draws: &[Vec<Draw>],
        extents: &[(u32, u32)],
        gbuffer: &mut GBuffer,
    ) {
        for (i, (d, &extent)) in draws.iter().zip(extents).enumerate() {
            if extent.0 == 0 || extent.1 == 0 {
                continue;
            }
            let view = View {
                index: i,
                draws: d,
                layer: i as u32,
                extent,
            };
            self.raster.record(cmd, scene, &view, gbuffer);
        }
    }
}
