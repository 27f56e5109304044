//! Eye G-buffer: the scene rasterised from the camera into what later passes shade from. The
//! same raster, with one set of view uniforms per light view, fills the light G-buffers
//! (`light_gbuffer.rs`).
//!
//! ```text
//!   position  RGBA32F   camera-relative world position, w = 1 on geometry, 0 on background
//!   normal    RGBA16F   unit shading normal turned towards the viewer; w = ±1: the mesh side
//!   albedo    RGBA16F   Lambertian reflectance × base-colour texture (linear)
//!   material  R32_UINT  index into the material buffer
//!   depth     D32F      reversed-Z (1 at the near plane, 0 at infinity; the light views: 0 at
//!                       their far plane, `plan/lighting.rs`)
//! ```

use crate::gpu::scene::{Draw, GpuScene};
use crate::gpu::{
    uses, vk, Attachment, Binding, Blend, Buffer, Cmd, Depth, DescriptorLayout, DescriptorSet, Gpu,
    GraphicsDesc, Image, ImageDesc, Load, Pipeline, Use, ViewKind,
};
use crate::layout::{DrawPush, Vertex};
use crate::timing::pass_id::PassId;
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
    /// The colour images: position, normal, albedo, material.
    pub fn colours(&self) -> [&Image; 4] {
        [&self.position, &self.normal, &self.albedo, &self.material]
    }

    /// A G-buffer of `layers` layers (one per view), named `name.position` etc., sampled as
    /// `view` (light G-buffers are always arrays, even of one layer). Planned: the passes that
    /// read it add their uses (`gpu/image.rs`); its own are the attachments it is drawn into.
    pub fn new(
        gpu: &Arc<Gpu>,
        name: &str,
        width: u32,
        height: u32,
        layers: u32,
        view: ViewKind,
    ) -> GBuffer {
        let color = vk::ImageUsageFlags::COLOR_ATTACHMENT;
        let image = |part: &str, format, usage| {
            Image::planned(
                gpu,
                &ImageDesc {
                    name: &format!("{name}.{part}"),
                    format,
                    width,
                    height,
                    layers: layers.max(1),
                    usage,
                    view,
                },
            )
        };
        GBuffer {
            position: image("position", POSITION, color),
            normal: image("normal", NORMAL, color),
            albedo: image("albedo", ALBEDO, color),
            material: image("material", MATERIAL, color),
            depth: image(
                "depth",
                DEPTH,
                vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
            ),
        }
    }
}

/// One view of a [`GBufferPass`]: which uniforms, what to draw, and where.
pub struct View<'a> {
    /// Index into the `frames` the pass was created with.
    pub index: usize,
    pub draws: &'a [Draw],
    /// Layer of the G-buffer to draw into.
    pub layer: u32,
    /// Drawn into the top-left `extent` texels.
    pub extent: (u32, u32),
}

/// Rasterises G-buffers: the eye's (one view) or the lights' (one view per layer).
pub struct GBufferPass {
    name: PassId,
    pipeline: Pipeline,
    _frame_layout: DescriptorLayout,
    _texture_layout: DescriptorLayout,
    /// One set per view: its `FrameUniforms` and the materials.
    frame_sets: Vec<DescriptorSet>,
    /// One set per material (its base-colour texture, or white).
    material_sets: Vec<DescriptorSet>,
}

/// The eye G-buffer pass: [`GBufferPass`] with the camera as its only view.
pub type EyeGBufferPass = GBufferPass;

impl GBufferPass {
    /// A raster named `name` with one view per buffer in `frames` (each a `FrameUniforms`).
    /// Every view's projection reverses depth: the near plane at depth 1 (the eye's infinite
    /// reversed-Z projection, the photon light views' finite one, `plan/lighting.rs`), so the depth
    /// test keeps the greater depth and the attachment is cleared to 0.
    pub fn new(
        gpu: &Arc<Gpu>,
        name: PassId,
        scene: &GpuScene,
        frames: &[&Buffer],
    ) -> anyhow::Result<Self> {
        let graphics = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        // What each view's set binds: its uniforms and the (static, set-up) materials.
        let view_uses = |frame| [Use::Uniform(frame), Use::Read(&scene.materials)];
        let kinds = uses::kinds(&view_uses(&scene.materials));
        let frame_layout = DescriptorLayout::new(
            gpu,
            "eye_gbuffer.frame",
            &Binding::sequence(&kinds, graphics),
            frames.len().max(1) as u32,
        )?;
        let (texture_layout, material_sets) =
            material_texture_sets(gpu, PassId::EyeGbuffer.name(), scene)?;
        let frame_sets = frames
            .iter()
            .map(|f| frame_layout.allocate(&uses::writes(&view_uses(f))))
            .collect::<Result<Vec<_>, _>>()?;
        let attributes = super::vertex_attributes();
        let pipeline = Pipeline::graphics(
            gpu,
            &GraphicsDesc {
                name: name.name(),
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
                specialization: &[],
            },
        )?;
        Ok(Self {
            name,
            pipeline,
            _frame_layout: frame_layout,
            _texture_layout: texture_layout,
            frame_sets,
            material_sets,
        })
    }

    /// Draws `view` into its layer of `gbuffer`.
    pub fn record(&self, cmd: &Cmd, scene: &GpuScene, view: &View, gbuffer: &mut GBuffer) {
        let _scope = cmd.scope(self.name.name());
        let clear = |image| Attachment {
            image,
            layer: view.layer,
            load: Load::Clear([0.0; 4]),
        };
        cmd.begin_rendering(
            &gbuffer.colours().map(clear),
            Some(&Attachment {
                image: &gbuffer.depth,
                layer: view.layer,
                load: Load::Clear([0.0; 4]), // reversed depth: 0 is the far end
            }),
        );
        cmd.set_viewport(view.extent.0, view.extent.1);
        cmd.bind_pipeline(&self.pipeline);
        cmd.bind_sets(&self.pipeline, 0, &[self.frame_sets[view.index]]);
        draw_instances(cmd, &self.pipeline, scene, view.draws, &self.material_sets);
        cmd.end_rendering();
    }
}

/// The per-material descriptor sets of a raster pass that textures its surfaces: a layout with
/// one sampled image (set 1, binding 0 of the raster shaders) and one set per material holding
/// its base-colour texture, or white.
pub(crate) fn material_texture_sets(
    gpu: &Arc<Gpu>,
    name: &str,
    scene: &GpuScene,
) -> anyhow::Result<(DescriptorLayout, Vec<DescriptorSet>)> {
    // Each material's texture (uploaded at set-up, so no barrier each frame), or white.
    let texture = |image| [Use::Sampled(image, &scene.texture_sampler)];
    let layout = DescriptorLayout::new(
        gpu,
        &format!("{name}.texture"),
        &Binding::sequence(
            &uses::kinds(&texture(&scene.white)),
            vk::ShaderStageFlags::FRAGMENT,
        ),
        scene.material_textures.len().max(1) as u32,
    )?;
    let mut sets = Vec::new();
    for t in &scene.material_textures {
        let image = t.map_or(&scene.white, |i| &scene.textures[i]);
        sets.push(layout.allocate(&uses::writes(&texture(image)))?);
    }
    if sets.is_empty() {
        sets.push(layout.allocate(&uses::writes(&texture(&scene.white)))?);
    }
    Ok((layout, sets))
}

/// Draws `draws` with `pipeline` (bound, inside a rendering scope), binding each draw's
/// material texture set (from [`material_texture_sets`]) as set 1.
pub(crate) fn draw_instances(
    cmd: &Cmd,
    pipeline: &Pipeline,
    scene: &GpuScene,
    draws: &[Draw],
    material_sets: &[DescriptorSet],
) {
    cmd.bind_vertex_buffer(&scene.vertices);
    cmd.bind_index_buffer(&scene.indices);
    for d in draws {
        let set = material_sets
            .get(d.push.material.x as usize)
            .unwrap_or(&material_sets[0]);
        cmd.bind_sets(pipeline, 1, &[*set]);
        cmd.push_constants(pipeline, &d.push);
        cmd.draw_indexed(
            d.range.index_count,
            d.range.first_index,
            d.range.vertex_offset,
        );
    }
}
