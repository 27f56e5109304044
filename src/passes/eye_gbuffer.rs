//! Eye G-buffer: the scene rasterised from the camera into what later passes shade from.
//!
//! ```text
//!   position  RGBA32F   camera-relative world position, w = 1 on geometry, 0 on background
//!   normal    RGBA16F   unit shading normal turned towards the viewer
//!   albedo    RGBA16F   Lambertian reflectance × base-colour texture (linear)
//!   material  R32_UINT  index into the material buffer
//!   depth     D32F      reversed-Z (1 at the near plane, 0 at infinity)
//! ```

use crate::gpu::{
    vk, Attachment, Binding, BindingKind, Blend, Buffer, Cmd, Depth, DescriptorLayout,
    DescriptorSet, Gpu, GraphicsDesc, Image, ImageDesc, Load, Pipeline, ViewKind, Write,
};
use crate::gpu_scene::{Draw, GpuScene};
use crate::layout::{DrawPush, Vertex};
use std::sync::Arc;

pub const POSITION: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
pub const NORMAL: vk::Format = vk::Format::R16G16B16A16_SFLOAT;
pub const ALBEDO: vk::Format = vk::Format::R16G16B16A16_SFLOAT;
pub const MATERIAL: vk::Format = vk::Format::R32_UINT;
pub const DEPTH: vk::Format = vk::Format::D32_SFLOAT;

/// The eye G-buffer's images.
pub struct GBuffer {
    pub position: Image,
    pub normal: Image,
    pub albedo: Image,
    pub material: Image,
    pub depth: Image,
}

impl GBuffer {
    pub fn new(gpu: &Arc<Gpu>, width: u32, height: u32) -> anyhow::Result<GBuffer> {
        let color = vk::ImageUsageFlags::COLOR_ATTACHMENT
            | vk::ImageUsageFlags::SAMPLED
            | vk::ImageUsageFlags::TRANSFER_SRC;
        let image = |name: &str, format, usage| {
            Image::new(
                gpu,
                &ImageDesc {
                    name,
                    format,
                    width,
                    height,
                    layers: 1,
                    usage,
                    view: ViewKind::D2,
                },
            )
        };
        Ok(GBuffer {
            position: image("eye_gbuffer.position", POSITION, color)?,
            normal: image("eye_gbuffer.normal", NORMAL, color)?,
            albedo: image("eye_gbuffer.albedo", ALBEDO, color)?,
            material: image("eye_gbuffer.material", MATERIAL, color)?,
            depth: image(
                "eye_gbuffer.depth",
                DEPTH,
                vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::SAMPLED,
            )?,
        })
    }
}

pub struct EyeGBufferPass {
    pipeline: Pipeline,
    _frame_layout: DescriptorLayout,
    _texture_layout: DescriptorLayout,
    frame_set: DescriptorSet,
    /// One set per material (its base-colour texture, or white).
    material_sets: Vec<DescriptorSet>,
}

impl EyeGBufferPass {
    pub fn new(gpu: &Arc<Gpu>, scene: &GpuScene, frame: &Buffer) -> anyhow::Result<Self> {
        let graphics = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        let frame_layout = DescriptorLayout::new(
            gpu,
            "eye_gbuffer.frame",
            &[
                Binding {
                    binding: 0,
                    kind: BindingKind::UniformBuffer,
                    stages: graphics,
                },
                Binding {
                    binding: 1,
                    kind: BindingKind::StorageBuffer,
                    stages: graphics,
                },
            ],
            1,
        )?;
        let sets = scene.material_textures.len().max(1) as u32;
        let texture_layout = DescriptorLayout::new(
            gpu,
            "eye_gbuffer.texture",
            &[Binding {
                binding: 0,
                kind: BindingKind::SampledImage,
                stages: vk::ShaderStageFlags::FRAGMENT,
            }],
            sets,
        )?;
        let frame_set =
            frame_layout.allocate(&[Write::Buffer(frame), Write::Buffer(&scene.materials)])?;
        let mut material_sets = Vec::new();
        for t in &scene.material_textures {
            let image = t.map_or(&scene.white, |i| &scene.textures[i]);
            material_sets.push(texture_layout.allocate(&[Write::Image {
                image,
                sampler: &scene.texture_sampler,
            }])?);
        }
        if material_sets.is_empty() {
            material_sets.push(texture_layout.allocate(&[Write::Image {
                image: &scene.white,
                sampler: &scene.texture_sampler,
            }])?);
        }
        let attributes = super::vertex_attributes();
        let pipeline = Pipeline::graphics(
            gpu,
            &GraphicsDesc {
                name: "eye_gbuffer",
                vertex: &crate::gpu::shader_table::EYE_GBUFFER_VERT,
                fragment: Some(&crate::gpu::shader_table::EYE_GBUFFER_FRAG),
                vertex_stride: size_of::<Vertex>() as u32,
                vertex_attributes: &attributes,
                color_formats: &[POSITION, NORMAL, ALBEDO, MATERIAL],
                blend: Blend::Off,
                depth: Some(Depth {
                    format: DEPTH,
                    test: true,
                    write: true,
                    compare: vk::CompareOp::GREATER,
                    bias: None,
                }),
                // Surfaces are shaded from the side the viewer sees (the fragment shader turns
                // the normal), so nothing is culled: open and thin geometry stays visible.
                cull: vk::CullModeFlags::NONE,
                set_layouts: &[&frame_layout, &texture_layout],
                push_constant_size: size_of::<DrawPush>() as u32,
            },
        )?;
        Ok(Self {
            pipeline,
            _frame_layout: frame_layout,
            _texture_layout: texture_layout,
            frame_set,
            material_sets,
        })
    }

    pub fn record(&self, cmd: &Cmd, scene: &GpuScene, draws: &[Draw], gbuffer: &mut GBuffer) {
        let _scope = cmd.scope("eye_gbuffer");
        let clear = |image| Attachment {
            image,
            layer: 0,
            load: Load::Clear([0.0; 4]),
        };
        cmd.begin_rendering(
            &[
                clear(&gbuffer.position),
                clear(&gbuffer.normal),
                clear(&gbuffer.albedo),
                clear(&gbuffer.material),
            ],
            Some(&clear(&gbuffer.depth)),
        );
        cmd.bind_pipeline(&self.pipeline);
        cmd.bind_sets(&self.pipeline, 0, &[self.frame_set]);
        cmd.bind_vertex_buffer(&scene.vertices);
        cmd.bind_index_buffer(&scene.indices);
        for d in draws {
            let set = self
                .material_sets
                .get(d.push.material.x as usize)
                .unwrap_or(&self.material_sets[0]);
            cmd.bind_sets(&self.pipeline, 1, &[*set]);
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
