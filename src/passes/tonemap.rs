//! Tonemapping (compute): HDR radiance × 2^EV → operator → sRGB, into an 8-bit image.

use super::ComputeKernel;
use crate::config::settings::Tonemap;
use crate::gpu::{vk, Cmd, Filter, Gpu, Image, ImageDesc, Sampler, Shaders, Use, ViewKind};
use crate::timing::pass_id::PassId;
use std::sync::Arc;

pub const FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    exposure: f32,
    op: u32,
    width: u32,
    height: u32,
}

pub struct TonemapPass {
    kernel: ComputeKernel,
    sampler: Sampler,
}

/// The 8-bit output image (planned: the tonemapping adds its use; its own is the copy out of
/// it, read back or blitted to a window; the debug views, made later, write it as the
/// tonemapping does).
pub fn output(gpu: &Arc<Gpu>, width: u32, height: u32) -> Image {
    Image::planned(
        gpu,
        &ImageDesc {
            name: "tonemap.output",
            format: FORMAT,
            width,
            height,
            layers: 1,
            usage: vk::ImageUsageFlags::TRANSFER_SRC,
            view: ViewKind::D2,
        },
    )
}

impl TonemapPass {
    pub fn new(gpu: &Arc<Gpu>, hdr: &Image, ldr: &Image) -> anyhow::Result<Self> {
        let sampler = Sampler::new(gpu, "tonemap.nearest", Filter::Nearest, false)?;
        let kernel = ComputeKernel::new(
            gpu,
            PassId::Tonemap.name(),
            &crate::gpu::shader_table::TONEMAP_COMP,
            &Self::uses(hdr, ldr, &sampler),
            size_of::<Push>() as u32,
            &[],
        )?;
        Ok(Self { kernel, sampler })
    }

    /// What the pass uses, in the shader's binding order.
    fn uses<'a>(hdr: &'a Image, ldr: &'a Image, sampler: &'a Sampler) -> [Use<'a>; 2] {
        [Use::Sampled(hdr, sampler), Use::Storage(ldr)]
    }

    pub fn record(
        &self,
        cmd: &Cmd,
        hdr: &Image,
        tonemap: Tonemap,
        exposure_ev: f32,
        ldr: &mut Image,
    ) {
        let _scope = cmd.scope(PassId::Tonemap.name());
        cmd.uses(Shaders::Compute, &Self::uses(hdr, ldr, &self.sampler));
        let push = Push {
            exposure: exposure_ev.exp2(),
            op: tonemap.id(),
            width: ldr.width,
            height: ldr.height,
        };
        self.kernel
            .dispatch_with(cmd, &push, super::image_groups(ldr.width, ldr.height));
    }
}
