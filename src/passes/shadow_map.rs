//! Shadow maps: the scene's depth seen from every light view, one layer of the shadow atlas
//! each (see `plan/lighting.rs` for which views a light gets).

use crate::gpu::scene::{Draw, GpuScene};
use crate::gpu::{
    vk, Attachment, Cmd, Depth, Gpu, GpuResult, GraphicsDesc, Image, ImageDesc, Load, Pipeline,
    ViewKind,
};
use crate::layout::{DrawPush, Vertex};
use crate::timing::pass_id::PassId;
use std::sync::Arc;

pub const FORMAT: vk::Format = vk::Format::D32_SFLOAT;

pub struct ShadowMapPass {
    pipeline: Pipeline,
}

/// The depth array every light view renders into (planned: the passes that sample it add
/// their use).
pub fn atlas(gpu: &Arc<Gpu>, resolution: u32, layers: u32) -> Image {
    Image::planned(
        gpu,
        &ImageDesc {
            name: "shadow_atlas",
            format: FORMAT,
            width: resolution,
            height: resolution,
            layers: layers.max(1),
            usage: vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
            view: ViewKind::D2Array,
        },
    )
}

impl ShadowMapPass {
    pub fn new(gpu: &Arc<Gpu>) -> GpuResult<Self> {
        let attributes = super::vertex_attributes();
        let pipeline = Pipeline::graphics(
            gpu,
            &GraphicsDesc {
                name: "shadow_map",
                vertex: &crate::gpu::shader_table::SHADOW_MAP_VERT,
                fragment: None,
                vertex_stride: size_of::<Vertex>() as u32,
                vertex_attributes: &attributes[..1],
                color_formats: &[],
                blend: crate::gpu::Blend::Off,
                depth: Some(Depth {
                    format: FORMAT,
                    test: true,
                    write: true,
                    // Reversed depth (`plan/lighting.rs`): nearer is larger, and the bias pushes the
                    // stored depth away from the light, towards 0.
                    compare: vk::CompareOp::GREATER_OR_EQUAL,
                    bias: Some((-1.0, -1.5)),
                }),
                // Both faces: thin and open geometry must cast shadows too.
                cull: vk::CullModeFlags::NONE,
                set_layouts: &[],
                push_constant_size: size_of::<DrawPush>() as u32,
                specialization: &[],
            },
        )?;
        Ok(Self { pipeline })
    }

    /// Renders `views[i]` (each instance's draw for view i) into layer i of `atlas`.
    pub fn record(&self, cmd: &Cmd, scene: &GpuScene, views: &[Vec<Draw>], atlas: &mut Image) {
        let _scope = cmd.scope(PassId::ShadowMaps.name());
        for (layer, draws) in views.iter().enumerate() {
            cmd.begin_rendering(
                &[],
                Some(&Attachment {
                    image: atlas,
                    layer: layer as u32,
                    load: Load::Clear([0.0; 4]), // reversed depth: 0 is the far end
                }),
            );
            cmd.bind_pipeline(&self.pipeline);
            cmd.bind_vertex_buffer(&scene.vertices);
            cmd.bind_index_buffer(&scene.indices);
            for d in draws {
                cmd.push_constants(&self.pipeline, &d.push);
                cmd.draw_indexed(
                    d.range.index_count,
                    d.range.first_index,
                    d.range.vertex_offset,
                );
            }
            cmd.end_rendering();
        }
    }
}
