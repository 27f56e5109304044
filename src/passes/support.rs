//! Support normalisation (compute): the boundary correction of the global photons' estimate.
//!
//! DOCS_PLACEHOLDER

use super::eye_gbuffer::GBuffer;
use super::ComputeKernel;
use crate::gpu::{Access, BindingKind, Buffer, Cmd, Filter, Gpu, Image, Sampler, Write};
use std::sync::Arc;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    width: u32,
    height: u32,
    pad: [u32; 2],
}

pub struct SupportPass {
    kernel: ComputeKernel,
    _sampler: Sampler,
}

impl SupportPass {
    /// The pass over `total` (the full-resolution photon-volume target) and the two
    /// [`super::photon_volumes::support_targets`] beside it, reading the eye G-buffer and the
    /// frame's `view_proj`.
    pub fn new(
        gpu: &Arc<Gpu>,
        (frame, gbuffer): (&Buffer, &GBuffer),
        total: &Image,
        support: &[Image; 2],
    ) -> anyhow::Result<Self> {
        let sampler = Sampler::new(gpu, "support.nearest", Filter::Nearest, false)?;
        let image = |image| Write::Image {
            image,
            sampler: &sampler,
        };
        let kernel = ComputeKernel::new(
            gpu,
            "support",
            &crate::gpu::shader_table::SUPPORT_COMP,
            &[
                BindingKind::UniformBuffer,
                BindingKind::SampledImage,
                BindingKind::SampledImage,
                BindingKind::StorageImage,
                BindingKind::StorageImage,
                BindingKind::StorageImage,
            ],
            size_of::<Push>() as u32,
            &[
                Write::Buffer(frame),
                image(&gbuffer.position),
                image(&gbuffer.normal),
                Write::StorageImage(total),
                Write::StorageImage(&support[0]),
                Write::StorageImage(&support[1]),
            ],
            &[],
        )?;
        Ok(Self {
            kernel,
            _sampler: sampler,
        })
    }

    pub fn record(&self, cmd: &Cmd, gbuffer: &GBuffer, total: &Image, support: &[Image; 2]) {
        let _scope = cmd.scope("support");
        for image in [&gbuffer.position, &gbuffer.normal] {
            cmd.transition(image, Access::ComputeSampledRead);
        }
        for image in std::iter::once(total).chain(support) {
            cmd.transition(image, Access::ComputeStorageWrite);
        }
        let (width, height) = (total.width, total.height);
        let push = Push {
            width,
            height,
            pad: [0; 2],
        };
        self.kernel
            .dispatch_with(cmd, &push, super::image_groups(width, height));
    }
}
