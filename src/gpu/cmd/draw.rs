//! [`Cmd`]'s rendering scopes, pipeline and descriptor bindings, draws and dispatches.

use super::{Attachment, Cmd, Load, Resource};
use crate::gpu::access::Access;
use crate::gpu::pipeline::{DescriptorSet, Pipeline};
use crate::gpu::resources::Buffer;
use ash::vk;

impl Cmd<'_> {
    /// Begins dynamic rendering into `colors` (+ `depth`), with viewport and scissor set to the
    /// full extent of the first attachment. Transitions the attachments first.
    pub fn begin_rendering(&self, colors: &[Attachment], depth: Option<&Attachment>) {
        self.begin_rendering_after(&[], colors, depth);
    }

    /// [`Self::begin_rendering`], with the accesses `before` (a raster pass's declared uses:
    /// [`Cmd::begin_pass`]) in the same batch of barriers as the attachments'.
    pub fn begin_rendering_after(
        &self,
        before: &[(Resource, Access)],
        colors: &[Attachment],
        depth: Option<&Attachment>,
    ) {
        let extent = colors
            .first()
            .or(depth)
            .map(|a| a.image.extent())
            .unwrap_or_default();
        // Read-write: a blending pipeline reads the attachment even after a clear.
        let uses: Vec<_> = (before.iter().copied())
            .chain(
                (colors.iter()).map(|c| (Resource::Image(c.image), Access::ColorAttachmentBlend)),
            )
            .chain(depth.map(|d| (Resource::Image(d.image), Access::DepthAttachmentWrite)))
            .collect();
        self.barriers(&uses);
        let color_infos: Vec<_> = colors
            .iter()
            .map(|c| {
                let (load_op, clear) = match c.load {
                    Load::Clear(v) => (vk::AttachmentLoadOp::CLEAR, v),
                    Load::Keep => (vk::AttachmentLoadOp::LOAD, [0.0; 4]),
                };
                vk::RenderingAttachmentInfo::default()
                    .image_view(c.image.layer_view(c.layer))
                    .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                    .load_op(load_op)
                    .store_op(vk::AttachmentStoreOp::STORE)
                    .clear_value(vk::ClearValue {
                        color: vk::ClearColorValue { float32: clear },
                    })
            })
            .collect();
        let depth_info = depth.map(|d| {
            let (load_op, clear) = match d.load {
                Load::Clear(v) => (vk::AttachmentLoadOp::CLEAR, v[0]),
                Load::Keep => (vk::AttachmentLoadOp::LOAD, 0.0),
            };
            vk::RenderingAttachmentInfo::default()
                .image_view(d.image.layer_view(d.layer))
                .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
                .load_op(load_op)
                .store_op(vk::AttachmentStoreOp::STORE)
                .clear_value(vk::ClearValue {
                    depth_stencil: vk::ClearDepthStencilValue {
                        depth: clear,
                        stencil: 0,
                    },
                })
        });
        let area = vk::Rect2D {
            offset: vk::Offset2D::default(),
            extent,
        };
        let mut info = vk::RenderingInfo::default()
            .render_area(area)
            .layer_count(1)
            .color_attachments(&color_infos);
        if let Some(d) = &depth_info {
            info = info.depth_attachment(d);
        }
        let viewport = vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: extent.width as f32,
            height: extent.height as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        };
        // SAFETY: recording state, outside any rendering scope; attachments are live and in
        // the layouts named (transitioned above); dynamic rendering is enabled.
        unsafe {
            self.device().cmd_begin_rendering(self.raw, &info);
            self.device().cmd_set_viewport(self.raw, 0, &[viewport]);
            self.device().cmd_set_scissor(self.raw, 0, &[area]);
        }
    }

    /// Restricts drawing to the top-left `width`×`height` texels of the attachments.
    pub fn set_viewport(&self, width: u32, height: u32) {
        let viewport = vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: width as f32,
            height: height as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        };
        let scissor = vk::Rect2D {
            offset: vk::Offset2D::default(),
            extent: vk::Extent2D { width, height },
        };
        // SAFETY: recording state inside a rendering scope; viewport and scissor are dynamic
        // states of every graphics pipeline (pipeline.rs).
        unsafe {
            self.device().cmd_set_viewport(self.raw, 0, &[viewport]);
            self.device().cmd_set_scissor(self.raw, 0, &[scissor]);
        }
    }

    pub fn end_rendering(&self) {
        // SAFETY: paired with begin_rendering by the caller.
        unsafe { self.device().cmd_end_rendering(self.raw) };
    }

    pub fn bind_pipeline(&self, pipeline: &Pipeline) {
        // SAFETY: recording state; the pipeline is live.
        unsafe {
            self.device()
                .cmd_bind_pipeline(self.raw, pipeline.bind_point, pipeline.raw)
        };
    }

    pub fn bind_sets(&self, pipeline: &Pipeline, first: u32, sets: &[DescriptorSet]) {
        let raw: Vec<_> = sets.iter().map(|s| s.0).collect();
        // SAFETY: recording state; sets are compatible with the pipeline's layout by
        // construction (created from the same DescriptorLayouts).
        unsafe {
            self.device().cmd_bind_descriptor_sets(
                self.raw,
                pipeline.bind_point,
                pipeline.layout,
                first,
                &raw,
                &[],
            )
        };
    }

    pub fn push_constants<T: bytemuck::Pod>(&self, pipeline: &Pipeline, value: &T) {
        assert_eq!(
            size_of::<T>() as u32,
            pipeline.push_size,
            "push constants of the wrong size for this pipeline"
        );
        // SAFETY: recording state; the pipeline layout declares a push range of exactly
        // size_of::<T>() bytes for these stages (asserted above).
        unsafe {
            self.device().cmd_push_constants(
                self.raw,
                pipeline.layout,
                pipeline.push_stages,
                0,
                bytemuck::bytes_of(value),
            )
        };
    }

    pub fn bind_vertex_buffer(&self, buffer: &Buffer) {
        // SAFETY: recording state; the buffer is live with VERTEX_BUFFER usage.
        unsafe {
            self.device()
                .cmd_bind_vertex_buffers(self.raw, 0, &[buffer.raw], &[0])
        };
    }

    pub fn bind_index_buffer(&self, buffer: &Buffer) {
        // SAFETY: recording state; the buffer is live with INDEX_BUFFER usage.
        unsafe {
            self.device()
                .cmd_bind_index_buffer(self.raw, buffer.raw, 0, vk::IndexType::UINT32)
        };
    }

    pub fn draw(&self, vertices: u32, instances: u32) {
        // SAFETY: recording state inside a rendering scope with a graphics pipeline bound.
        unsafe { self.device().cmd_draw(self.raw, vertices, instances, 0, 0) };
    }

    pub fn draw_indexed(&self, indices: u32, first_index: u32, vertex_offset: i32) {
        // SAFETY: recording state inside a rendering scope; index/vertex buffers bound.
        unsafe {
            self.device()
                .cmd_draw_indexed(self.raw, indices, 1, first_index, vertex_offset, 0)
        };
    }

    /// Draws `instances` instances of the bound index buffer's first `indices` indices.
    pub fn draw_indexed_instanced(&self, indices: u32, instances: u32) {
        // SAFETY: recording state inside a rendering scope; index/vertex buffers bound.
        unsafe {
            self.device()
                .cmd_draw_indexed(self.raw, indices, instances, 0, 0, 0)
        };
    }

    pub fn dispatch(&self, x: u32, y: u32, z: u32) {
        // SAFETY: recording state with a compute pipeline bound.
        unsafe { self.device().cmd_dispatch(self.raw, x, y, z) };
    }
}
