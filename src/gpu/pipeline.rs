//! Descriptor set layouts, descriptor sets and pipelines (graphics with dynamic rendering, and
//! compute). A pass describes what it needs in plain structs; this file turns them into Vulkan
//! objects.
//!
//! Shader variants are specialisation constants: a pipeline description lists
//! [`SpecConstant`]s (id, 32-bit value), and every stage of the pipeline receives all of them.
//! An id a stage does not declare is ignored (Vulkan 1.3 §10.8: a map entry whose
//! `constantID` the module does not use has no effect), so one list serves every stage.

use super::device::WaitingWrite;
use super::device::{Gpu, Retired};
use super::error::{vk_err, GpuResult};
use super::image::Image;
use super::resources::{Buffer, Sampler};
use super::shaders::{Module, Shader};
use ash::vk;
use std::sync::Arc;

/// What a descriptor binding holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BindingKind {
    UniformBuffer,
    StorageBuffer,
    /// Combined image + sampler.
    SampledImage,
    StorageImage,
}

impl BindingKind {
    fn vk(self) -> vk::DescriptorType {
        match self {
            BindingKind::UniformBuffer => vk::DescriptorType::UNIFORM_BUFFER,
            BindingKind::StorageBuffer => vk::DescriptorType::STORAGE_BUFFER,
            BindingKind::SampledImage => vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
            BindingKind::StorageImage => vk::DescriptorType::STORAGE_IMAGE,
        }
    }
}

/// One binding of a descriptor set layout.
#[derive(Clone, Copy, Debug)]
pub struct Binding {
    pub binding: u32,
    pub kind: BindingKind,
    pub stages: vk::ShaderStageFlags,
}

impl Binding {
    /// Bindings 0, 1, 2… of `kinds`, in order, all visible to `stages`: the layout of every
    /// pass whose shader numbers its bindings in declaration order.
    pub fn sequence(kinds: &[BindingKind], stages: vk::ShaderStageFlags) -> Vec<Binding> {
        kinds
            .iter()
            .enumerate()
            .map(|(i, &kind)| Binding {
                binding: i as u32,
                kind,
                stages,
            })
            .collect()
    }
}

/// A descriptor set layout plus a pool sized for `max_sets` sets of it.
pub struct DescriptorLayout {
    gpu: Arc<Gpu>,
    pub(super) raw: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    bindings: Vec<Binding>,
}

/// A descriptor set allocated from a [`DescriptorLayout`]'s pool.
#[derive(Clone, Copy, Debug)]
pub struct DescriptorSet(pub(super) vk::DescriptorSet);

/// What to write into one binding.
pub enum Write<'a> {
    Buffer(&'a Buffer),
    /// A sampled image in `SHADER_READ_ONLY_OPTIMAL`.
    Image {
        image: &'a Image,
        sampler: &'a Sampler,
    },
    StorageImage(&'a Image),
}

impl DescriptorLayout {
    pub fn new(
        gpu: &Arc<Gpu>,
        name: &str,
        bindings: &[Binding],
        max_sets: u32,
    ) -> GpuResult<DescriptorLayout> {
        let vk_bindings: Vec<_> = bindings
            .iter()
            .map(|b| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(b.binding)
                    .descriptor_type(b.kind.vk())
                    .descriptor_count(1)
                    .stage_flags(b.stages)
            })
            .collect();
        let info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&vk_bindings);
        let device = gpu.raw();
        // SAFETY: the device is live; the bindings are valid and unique by construction.
        let raw = unsafe { device.create_descriptor_set_layout(&info, None) }
            .map_err(vk_err("vkCreateDescriptorSetLayout"))?;
        gpu.set_name(raw, name);
        let mut sizes: Vec<vk::DescriptorPoolSize> = Vec::new();
        for b in bindings {
            let ty = b.kind.vk();
            match sizes.iter_mut().find(|s| s.ty == ty) {
                Some(s) => s.descriptor_count += max_sets,
                None => sizes.push(vk::DescriptorPoolSize {
                    ty,
                    descriptor_count: max_sets,
                }),
            }
        }
        let pool_info = vk::DescriptorPoolCreateInfo::default()
            .max_sets(max_sets.max(1))
            .pool_sizes(&sizes);
        // SAFETY: the device is live; pool sizes are non-empty for non-empty layouts.
        let pool = unsafe { device.create_descriptor_pool(&pool_info, None) }
            .map_err(vk_err("vkCreateDescriptorPool"))?;
        gpu.set_name(pool, &format!("{name}.pool"));
        Ok(DescriptorLayout {
            gpu: gpu.clone(),
            raw,
            pool,
            bindings: bindings.to_vec(),
        })
    }

    /// Allocates a set and writes `writes` into bindings 0, 1, 2… in order of the layout.
    pub fn allocate(&self, writes: &[Write]) -> GpuResult<DescriptorSet> {
        let layouts = [self.raw];
        let info = vk::DescriptorSetAllocateInfo::default()
            .descriptor_pool(self.pool)
            .set_layouts(&layouts);
        // SAFETY: pool and layout are live objects of this device.
        let set = unsafe { self.gpu.raw().allocate_descriptor_sets(&info) }
            .map_err(vk_err("vkAllocateDescriptorSets"))?[0];
        let set = DescriptorSet(set);
        self.update(set, writes);
        Ok(set)
    }

    /// Rewrites the bindings of `set` (which must not be in use by the GPU).
    pub fn update(&self, set: DescriptorSet, writes: &[Write]) {
        let mut buffer_infos = Vec::new();
        let mut image_infos = Vec::new();
        for (w, b) in writes.iter().zip(&self.bindings) {
            match w {
                Write::Buffer(buf) => buffer_infos.push((
                    b,
                    [vk::DescriptorBufferInfo {
                        buffer: buf.raw,
                        offset: 0,
                        range: vk::WHOLE_SIZE,
                    }],
                )),
                Write::Image { image, sampler } => {
                    let layout = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;
                    self.image_write(set, b, (image, sampler.raw, layout), &mut image_infos)
                }
                Write::StorageImage(image) => {
                    let layout = vk::ImageLayout::GENERAL;
                    let none = vk::Sampler::null();
                    self.image_write(set, b, (image, none, layout), &mut image_infos)
                }
            }
        }
        let mut vk_writes = Vec::new();
        for (b, info) in &buffer_infos {
            vk_writes.push(
                vk::WriteDescriptorSet::default()
                    .dst_set(set.0)
                    .dst_binding(b.binding)
                    .descriptor_type(b.kind.vk())
                    .buffer_info(info),
            );
        }
        for (b, info) in &image_infos {
            vk_writes.push(
                vk::WriteDescriptorSet::default()
                    .dst_set(set.0)
                    .dst_binding(b.binding)
                    .descriptor_type(b.kind.vk())
                    .image_info(info),
            );
        }
        // SAFETY: every handle written is live; the set is not in use by pending GPU work
        // (callers update only sets they own and have waited for).
        unsafe { self.gpu.raw().update_descriptor_sets(&vk_writes, &[]) };
    }

    /// The write of one image binding: now if the image is made, else once
    /// [`Gpu::make_planned`] has made it (`planned.rs`).
    fn image_write<'b>(
        &self,
        set: DescriptorSet,
        binding: &'b Binding,
        (image, sampler, layout): (&Image, vk::Sampler, vk::ImageLayout),
        now: &mut Vec<(&'b Binding, [vk::DescriptorImageInfo; 1])>,
    ) {
        if image.is_made() {
            self.gpu.forget_write(set.0, binding.binding);
            now.push((
                binding,
                [vk::DescriptorImageInfo {
                    sampler,
                    image_view: image.view(),
                    image_layout: layout,
                }],
            ));
        } else {
            self.gpu.defer_write(WaitingWrite {
                pool: self.pool,
                set: set.0,
                binding: binding.binding,
                ty: binding.kind.vk(),
                image: image.planned_ref(),
                sampler,
                layout,
            });
        }
    }
}

impl Drop for DescriptorLayout {
    fn drop(&mut self) {
        self.gpu.forget_writes(self.pool);
        self.gpu.retire(Retired::DescriptorPool(self.pool));
        self.gpu.retire(Retired::DescriptorSetLayout(self.raw));
    }
}

/// One specialisation constant: `layout(constant_id = id)` in GLSL gets `value` (a `bool`
/// constant reads 0 as false and anything else as true; 32-bit `int`/`uint`/`float` constants
/// read the bits).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SpecConstant {
    pub id: u32,
    pub value: u32,
}

impl SpecConstant {
    /// A `bool` constant (`VkBool32`).
    pub fn bool(id: u32, value: bool) -> Self {
        Self {
            id,
            value: u32::from(value),
        }
    }
}

/// The map entries and data of a `VkSpecializationInfo` for `constants`: entry i reads the
/// 4 bytes at offset 4·i of the data.
struct Specialization {
    entries: Vec<vk::SpecializationMapEntry>,
    data: Vec<u8>,
}

impl Specialization {
    fn new(constants: &[SpecConstant]) -> Self {
        let entries = constants
            .iter()
            .enumerate()
            .map(|(i, c)| vk::SpecializationMapEntry {
                constant_id: c.id,
                offset: (i * size_of::<u32>()) as u32,
                size: size_of::<u32>(),
            })
            .collect();
        let data = constants
            .iter()
            .flat_map(|c| c.value.to_ne_bytes())
            .collect();
        Self { entries, data }
    }

    /// The info to chain into a stage; borrows `self`.
    fn info(&self) -> vk::SpecializationInfo<'_> {
        vk::SpecializationInfo::default()
            .map_entries(&self.entries)
            .data(&self.data)
    }
}

/// Colour blending of a graphics pipeline.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Blend {
    Off,
    /// `dst += src` (photon volumes, light accumulation).
    Additive,
}

/// Depth testing of a graphics pipeline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Depth {
    pub format: vk::Format,
    pub test: bool,
    pub write: bool,
    pub compare: vk::CompareOp,
    /// (constant, slope) depth bias, for shadow maps.
    pub bias: Option<(f32, f32)>,
}

/// One vertex attribute in the single interleaved vertex binding.
#[derive(Clone, Copy, Debug)]
pub struct VertexAttribute {
    pub location: u32,
    pub format: vk::Format,
    pub offset: u32,
}

/// A graphics pipeline description (dynamic rendering, dynamic viewport and scissor).
pub struct GraphicsDesc<'a> {
    pub name: &'a str,
    pub vertex: &'a Shader,
    pub fragment: Option<&'a Shader>,
    pub vertex_stride: u32,
    pub vertex_attributes: &'a [VertexAttribute],
    pub color_formats: &'a [vk::Format],
    pub blend: Blend,
    pub depth: Option<Depth>,
    pub cull: vk::CullModeFlags,
    pub set_layouts: &'a [&'a DescriptorLayout],
    pub push_constant_size: u32,
    /// Specialisation constants of both stages (empty: every constant keeps its default).
    pub specialization: &'a [SpecConstant],
}

/// A compute pipeline description.
pub struct ComputeDesc<'a> {
    pub name: &'a str,
    pub shader: &'a Shader,
    pub set_layouts: &'a [&'a DescriptorLayout],
    pub push_constant_size: u32,
    /// Specialisation constants (empty: every constant keeps its default).
    pub specialization: &'a [SpecConstant],
}

/// A pipeline and its layout.
pub struct Pipeline {
    gpu: Arc<Gpu>,
    pub(super) raw: vk::Pipeline,
    pub(super) layout: vk::PipelineLayout,
    pub(super) bind_point: vk::PipelineBindPoint,
    pub(super) push_stages: vk::ShaderStageFlags,
    /// Bytes of push constants the layout declares.
    pub(super) push_size: u32,
}

fn create_layout(
    gpu: &Gpu,
    name: &str,
    set_layouts: &[&DescriptorLayout],
    push_size: u32,
    push_stages: vk::ShaderStageFlags,
) -> GpuResult<vk::PipelineLayout> {
    let sets: Vec<_> = set_layouts.iter().map(|l| l.raw).collect();
    let ranges = [vk::PushConstantRange {
        stage_flags: push_stages,
        offset: 0,
        size: push_size,
    }];
    let mut info = vk::PipelineLayoutCreateInfo::default().set_layouts(&sets);
    if push_size > 0 {
        info = info.push_constant_ranges(&ranges);
    }
    // SAFETY: the device is live and all set layouts are live objects of it.
    let layout = unsafe { gpu.raw().create_pipeline_layout(&info, None) }
        .map_err(vk_err("vkCreatePipelineLayout"))?;
    gpu.set_name(layout, &format!("{name}.layout"));
    Ok(layout)
}

impl Pipeline {
    pub fn graphics(gpu: &Arc<Gpu>, desc: &GraphicsDesc) -> GpuResult<Pipeline> {
        let push_stages = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        let layout = create_layout(
            gpu,
            desc.name,
            desc.set_layouts,
            desc.push_constant_size,
            push_stages,
        )?;
        // The layout is retired if anything below fails.
        let layout_guard = LayoutGuard(gpu, layout);
        let vs = Module::new(gpu, desc.vertex)?;
        let fs = desc.fragment.map(|f| Module::new(gpu, f)).transpose()?;
        let specialization = Specialization::new(desc.specialization);
        let specialization_info = specialization.info();
        let mut stages = vec![vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::VERTEX)
            .module(vs.raw)
            .name(c"main")
            .specialization_info(&specialization_info)];
        if let Some(fs) = &fs {
            stages.push(
                vk::PipelineShaderStageCreateInfo::default()
                    .stage(vk::ShaderStageFlags::FRAGMENT)
                    .module(fs.raw)
                    .name(c"main")
                    .specialization_info(&specialization_info),
            );
        }
        let vb = [vk::VertexInputBindingDescription {
            binding: 0,
            stride: desc.vertex_stride,
            input_rate: vk::VertexInputRate::VERTEX,
        }];
        let attrs: Vec<_> = desc
            .vertex_attributes
            .iter()
            .map(|a| vk::VertexInputAttributeDescription {
                location: a.location,
                binding: 0,
                format: a.format,
                offset: a.offset,
            })
            .collect();
        let mut vertex_input = vk::PipelineVertexInputStateCreateInfo::default();
        if !attrs.is_empty() {
            vertex_input = vertex_input
                .vertex_binding_descriptions(&vb)
                .vertex_attribute_descriptions(&attrs);
        }
        let input_assembly = vk::PipelineInputAssemblyStateCreateInfo::default()
            .topology(vk::PrimitiveTopology::TRIANGLE_LIST);
        let viewport = vk::PipelineViewportStateCreateInfo::default()
            .viewport_count(1)
            .scissor_count(1);
        let mut raster = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .cull_mode(desc.cull)
            .front_face(vk::FrontFace::COUNTER_CLOCKWISE)
            .line_width(1.0);
        if let Some((constant, slope)) = desc.depth.and_then(|d| d.bias) {
            raster = raster
                .depth_bias_enable(true)
                .depth_bias_constant_factor(constant)
                .depth_bias_slope_factor(slope);
        }
        let multisample = vk::PipelineMultisampleStateCreateInfo::default()
            .rasterization_samples(vk::SampleCountFlags::TYPE_1);
        let depth_state = match desc.depth {
            Some(d) => vk::PipelineDepthStencilStateCreateInfo::default()
                .depth_test_enable(d.test)
                .depth_write_enable(d.write)
                .depth_compare_op(d.compare),
            None => vk::PipelineDepthStencilStateCreateInfo::default(),
        };
        let attachment = match desc.blend {
            Blend::Off => vk::PipelineColorBlendAttachmentState::default()
                .color_write_mask(vk::ColorComponentFlags::RGBA),
            Blend::Additive => vk::PipelineColorBlendAttachmentState::default()
                .blend_enable(true)
                .src_color_blend_factor(vk::BlendFactor::ONE)
                .dst_color_blend_factor(vk::BlendFactor::ONE)
                .color_blend_op(vk::BlendOp::ADD)
                .src_alpha_blend_factor(vk::BlendFactor::ONE)
                .dst_alpha_blend_factor(vk::BlendFactor::ONE)
                .alpha_blend_op(vk::BlendOp::ADD)
                .color_write_mask(vk::ColorComponentFlags::RGBA),
        };
        let attachments = vec![attachment; desc.color_formats.len()];
        let blend = vk::PipelineColorBlendStateCreateInfo::default().attachments(&attachments);
        let dynamic_states = [vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR];
        let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
        let mut rendering =
            vk::PipelineRenderingCreateInfo::default().color_attachment_formats(desc.color_formats);
        if let Some(d) = desc.depth {
            rendering = rendering.depth_attachment_format(d.format);
        }
        let info = vk::GraphicsPipelineCreateInfo::default()
            .stages(&stages)
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&input_assembly)
            .viewport_state(&viewport)
            .rasterization_state(&raster)
            .multisample_state(&multisample)
            .depth_stencil_state(&depth_state)
            .color_blend_state(&blend)
            .dynamic_state(&dynamic)
            .layout(layout)
            .push_next(&mut rendering);
        // SAFETY: every referenced object (modules, layout) is live; the create info is
        // complete for dynamic rendering (no render pass); the specialisation data outlives
        // the call and every map entry lies inside it (4 bytes at 4·i).
        let raw = unsafe {
            gpu.raw()
                .create_graphics_pipelines(vk::PipelineCache::null(), &[info], None)
        }
        .map_err(|(_, e)| vk_err("vkCreateGraphicsPipelines")(e))?[0];
        gpu.set_name(raw, desc.name);
        std::mem::forget(layout_guard);
        Ok(Pipeline {
            gpu: gpu.clone(),
            raw,
            layout,
            bind_point: vk::PipelineBindPoint::GRAPHICS,
            push_stages,
            push_size: desc.push_constant_size,
        })
    }

    pub fn compute(gpu: &Arc<Gpu>, desc: &ComputeDesc) -> GpuResult<Pipeline> {
        let push_stages = vk::ShaderStageFlags::COMPUTE;
        let layout = create_layout(
            gpu,
            desc.name,
            desc.set_layouts,
            desc.push_constant_size,
            push_stages,
        )?;
        let layout_guard = LayoutGuard(gpu, layout);
        let module = Module::new(gpu, desc.shader)?;
        let specialization = Specialization::new(desc.specialization);
        let specialization_info = specialization.info();
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module.raw)
            .name(c"main")
            .specialization_info(&specialization_info);
        let info = vk::ComputePipelineCreateInfo::default()
            .stage(stage)
            .layout(layout);
        // SAFETY: module and layout are live objects of this device; the specialisation data
        // outlives the call and every map entry lies inside it (4 bytes at 4·i).
        let raw = unsafe {
            gpu.raw()
                .create_compute_pipelines(vk::PipelineCache::null(), &[info], None)
        }
        .map_err(|(_, e)| vk_err("vkCreateComputePipelines")(e))?[0];
        gpu.set_name(raw, desc.name);
        std::mem::forget(layout_guard);
        Ok(Pipeline {
            gpu: gpu.clone(),
            raw,
            layout,
            bind_point: vk::PipelineBindPoint::COMPUTE,
            push_stages,
            push_size: desc.push_constant_size,
        })
    }
}

/// Destroys a pipeline layout unless forgotten (the error paths of pipeline creation).
struct LayoutGuard<'a>(&'a Gpu, vk::PipelineLayout);

impl Drop for LayoutGuard<'_> {
    fn drop(&mut self) {
        // SAFETY: the layout was created by this device and no pipeline uses it yet.
        unsafe { self.0.raw().destroy_pipeline_layout(self.1, None) };
    }
}

impl Drop for Pipeline {
    fn drop(&mut self) {
        self.gpu.retire(Retired::Pipeline(self.raw, self.layout));
    }
}
