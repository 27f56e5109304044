//! Accumulate (compute): progressive accumulation of a still view. Each frame's radiance (direct
//! light, the photon-mapped estimate and the glass) joins the running mean of the frames since
//! the last reset, and the mean replaces the radiance, so the tonemap, the PNG and the EXR show
//! the average of every frame so far:
//!
//! ```text
//!  radiance (this frame) ──┐
//!                          ├─► mean = acc + (radiance − acc)/(n + 1) ──► accumulation (n + 1 frames)
//!  accumulation (n frames)─┘                                         └─► radiance ──► tonemap
//! ```
//!
//! The renderer decides `n` (`render/frame.rs`: 0 after anything but the exposure or tonemap changed)
//! and gives each accumulated frame a new photon sample and a smaller kernel
//! (`photon_frame.rs`, `PhotonFrame::set_sample`), so the mean converges (docs/accuracy.md,
//! "Progressive accumulation").

use super::ComputeKernel;
use crate::gpu::{vk, Cmd, Gpu, Image, ImageDesc, Shaders, Use, ViewKind};
use crate::timing::pass_id::PassId;
use std::sync::Arc;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    width: u32,
    height: u32,
    /// Frames already in the accumulation image (0: this frame starts it).
    frames: u32,
    pad: u32,
}

pub struct AccumulatePass {
    kernel: ComputeKernel,
    /// The running mean, RGBA f32 like the radiance.
    accumulation: Image,
}

impl AccumulatePass {
    pub fn new(gpu: &Arc<Gpu>, radiance: &Image) -> anyhow::Result<Self> {
        let accumulation = Image::planned(
            gpu,
            &ImageDesc {
                name: "accumulation",
                format: vk::Format::R32G32B32A32_SFLOAT,
                width: radiance.width,
                height: radiance.height,
                layers: 1,
                usage: vk::ImageUsageFlags::empty(),
                view: ViewKind::D2,
            },
        );
        let kernel = ComputeKernel::new(
            gpu,
            PassId::Accumulate.name(),
            &crate::gpu::shader_table::ACCUMULATE_COMP,
            &Self::uses(radiance, &accumulation),
            size_of::<Push>() as u32,
            &[],
        )?;
        Ok(Self {
            kernel,
            accumulation,
        })
    }

    /// What the pass uses, in the shader's binding order.
    fn uses<'a>(radiance: &'a Image, accumulation: &'a Image) -> [Use<'a>; 2] {
        [Use::Storage(radiance), Use::Storage(accumulation)]
    }

    /// Adds `radiance` to the mean of the `frames` frames before it and writes the mean back.
    pub fn record(&mut self, cmd: &Cmd, radiance: &mut Image, frames: u32) {
        let _scope = cmd.scope(PassId::Accumulate.name());
        cmd.uses(Shaders::Compute, &Self::uses(radiance, &self.accumulation));
        let push = Push {
            width: radiance.width,
            height: radiance.height,
            frames,
            pad: 0,
        };
        self.kernel.dispatch_with(
            cmd,
            &push,
            super::image_groups(radiance.width, radiance.height),
        );
    }
}
