//! Tonemapping (compute): HDR radiance × 2^EV → operator → sRGB, into an 8-bit image.

use super::ComputeKernel;
use crate::gpu::{
    vk, Access, BindingKind, Cmd, Filter, Gpu, Image, ImageDesc, Sampler, ViewKind, Write,
};
use crate::pass_id::PassId;
pub use crate::settings::Tonemap;
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
    _sampler: Sampler,
}

/// The 8-bit output image.
pub fn output(gpu: &Arc<Gpu>, width: u32, height: u32) -> anyhow::Result<Image> {
    Ok(Image::new(
        gpu,
        &ImageDesc {
            name: "tonemap.output",
            format: FORMAT,
            width,
            height,
            layers: 1,
            usage: vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC,
            view: ViewKind::D2,
        },
    )?)
}

impl TonemapPass {
    pub fn new(gpu: &Arc<Gpu>, hdr: &Image, ldr: &Image) -> anyhow::Result<Self> {
        let sampler = Sampler::new(gpu, "tonemap.nearest", Filter::Nearest, false)?;
        let kernel = ComputeKernel::new(
            gpu,
            PassId::Tonemap.name(),
            &crate::gpu::shader_table::TONEMAP_COMP,
            &[BindingKind::SampledImage, BindingKind::StorageImage],
            size_of::<Push>() as u32,
            &[
                Write::Image {
                    image: hdr,
                    sampler: &sampler,
                },
                Write::StorageImage(ldr),
            ],
            &[],
        )?;
        Ok(Self {
            kernel,
            _sampler: sampler,
        })
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
        cmd.transition(hdr, Access::ComputeSampledRead);
        cmd.transition(ldr, Access::ComputeStorageWrite);
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
