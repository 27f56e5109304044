//! The scene on the GPU: one interleaved vertex buffer and one index buffer for every mesh,
//! the material buffer, the base-colour textures, and each instance's transform in double
//! precision (made camera-relative every frame, see [`GpuScene::draws`]). Instances move by
//! host writes only ([`GpuScene::set_instance_transform`]): a draw's model matrix is a push
//! constant computed from its transform every frame, so nothing on the GPU changes.

use crate::gpu::{vk, Access, Buffer, Filter, Gpu, Image, ImageDesc, Sampler, ViewKind};
use crate::layout::{
    DrawPush, GpuMaterial, Vertex, MATERIAL_DOUBLE_SIDED, MATERIAL_FRESNEL, MATERIAL_TEXTURED,
};
use crate::scene::{Aabb, Material, Scene};
use anyhow::Context;
use glam::{DMat4, DVec3, UVec4};
use std::sync::Arc;

/// Where one mesh lives in the shared vertex and index buffers.
#[derive(Clone, Copy, Debug)]
pub struct MeshRange {
    pub first_index: u32,
    pub index_count: u32,
    pub vertex_offset: i32,
}

/// One instance to draw.
#[derive(Clone, Copy, Debug)]
pub struct InstanceDraw {
    pub mesh: usize,
    pub material: u32,
    /// World-from-object, in double precision.
    pub transform: DMat4,
}

/// Instance `i` of `scene` as drawn at its current transform.
fn instance_draw(scene: &Scene, i: usize) -> InstanceDraw {
    let inst = &scene.instances[i];
    InstanceDraw {
        mesh: inst.mesh,
        material: scene.meshes[inst.mesh].material as u32,
        transform: inst.transform.as_dmat4(),
    }
}

/// What a raster pass needs to draw one instance.
#[derive(Clone, Copy, Debug)]
pub struct Draw {
    /// The scene instance drawn.
    pub instance: usize,
    /// The scene mesh drawn.
    pub mesh: usize,
    pub range: MeshRange,
    pub push: DrawPush,
}

pub struct GpuScene {
    pub vertices: Buffer,
    pub indices: Buffer,
    pub meshes: Vec<MeshRange>,
    pub instances: Vec<InstanceDraw>,
    pub materials: Buffer,
    /// One image per scene texture; `white` stands in for untextured materials.
    pub textures: Vec<Image>,
    pub white: Image,
    pub texture_sampler: Sampler,
    /// Texture of each material (index into `textures`), if any.
    pub material_textures: Vec<Option<usize>>,
    /// Whether each material has a delta lobe (perfect mirror or refraction): such surfaces
    /// are drawn by the translucent pass, not into the eye G-buffer.
    pub material_delta: Vec<bool>,
    /// Bounds of the geometry over its whole animation (`Scene::motion_bounds`): what light
    /// views and kernel sizes are fitted to.
    pub bounds: Aabb,
    pub triangles: usize,
}

/// The GPU form of a material (the über-BSDF parameters of `photon::bsdf`).
pub fn gpu_material(m: &Material) -> GpuMaterial {
    let mut flags = 0;
    if m.fresnel {
        flags |= MATERIAL_FRESNEL;
    }
    if m.lambertian_texture.is_some() {
        flags |= MATERIAL_TEXTURED;
    }
    if m.double_sided {
        flags |= MATERIAL_DOUBLE_SIDED;
    }
    // A perfect mirror's exponent is infinite; shaders test `exponent >= 1e20`.
    let exponent = if m.exponent.is_finite() {
        m.exponent
    } else {
        1e30
    };
    GpuMaterial {
        lambertian: m.lambertian.extend(0.0),
        glossy: m.glossy.extend(exponent),
        transmission: m.transmission.extend(m.ior),
        emission: m.emission.extend(0.0),
        flags: UVec4::new(flags, 0, 0, 0),
    }
}

impl GpuScene {
    pub fn new(gpu: &Arc<Gpu>, scene: &Scene) -> anyhow::Result<GpuScene> {
        let mut vertices: Vec<Vertex> = Vec::new();
        let mut indices: Vec<u32> = Vec::new();
        let mut meshes = Vec::with_capacity(scene.meshes.len());
        for mesh in &scene.meshes {
            let range = MeshRange {
                first_index: u32::try_from(indices.len()).context("too many indices")?,
                index_count: u32::try_from(mesh.triangles.len() * 3).context("too many indices")?,
                vertex_offset: i32::try_from(vertices.len()).context("too many vertices")?,
            };
            for (i, p) in mesh.positions.iter().enumerate() {
                vertices.push(Vertex {
                    position: p.to_array(),
                    normal: mesh.normals.get(i).copied().unwrap_or_default().to_array(),
                    uv: mesh.uvs.get(i).copied().unwrap_or_default().to_array(),
                });
            }
            indices.extend(mesh.triangles.iter().flatten());
            meshes.push(range);
        }
        let vertices = gpu.upload_buffer(
            "scene.vertices",
            vk::BufferUsageFlags::VERTEX_BUFFER,
            bytemuck::cast_slice(&vertices),
            Access::VertexInput,
        )?;
        let indices = gpu.upload_buffer(
            "scene.indices",
            vk::BufferUsageFlags::INDEX_BUFFER,
            bytemuck::cast_slice(&indices),
            Access::IndexInput,
        )?;
        let materials: Vec<GpuMaterial> = if scene.materials.is_empty() {
            vec![gpu_material(&Material::default())]
        } else {
            scene.materials.iter().map(gpu_material).collect()
        };
        let materials = gpu.upload_buffer(
            "scene.materials",
            vk::BufferUsageFlags::STORAGE_BUFFER,
            bytemuck::cast_slice(&materials),
            Access::AnyShaderStorageRead,
        )?;
        let mut textures = Vec::new();
        for (i, t) in scene.textures.iter().enumerate() {
            let name = format!("scene.texture[{i}] {}", t.name);
            textures.push(gpu.upload_image(
                &ImageDesc {
                    name: &name,
                    format: vk::Format::R8G8B8A8_SRGB,
                    width: t.width,
                    height: t.height,
                    layers: 1,
                    usage: vk::ImageUsageFlags::SAMPLED,
                    view: ViewKind::D2,
                },
                &t.rgba8,
                Access::FragmentSampledRead,
            )?);
        }
        let white = gpu.upload_image(
            &ImageDesc {
                name: "scene.texture.white",
                format: vk::Format::R8G8B8A8_SRGB,
                width: 1,
                height: 1,
                layers: 1,
                usage: vk::ImageUsageFlags::SAMPLED,
                view: ViewKind::D2,
            },
            &[255; 4],
            Access::FragmentSampledRead,
        )?;
        let texture_sampler = Sampler::new(gpu, "scene.texture_sampler", Filter::Linear, true)?;
        let material_textures = scene
            .materials
            .iter()
            .map(|m| m.lambertian_texture.filter(|&t| t < textures.len()))
            .collect();
        let material_delta = scene
            .materials
            .iter()
            .map(Material::has_delta_lobe)
            .collect();
        let instances = (0..scene.instances.len())
            .map(|i| instance_draw(scene, i))
            .collect();
        Ok(GpuScene {
            vertices,
            indices,
            meshes,
            instances,
            materials,
            textures,
            white,
            texture_sampler,
            material_textures,
            material_delta,
            bounds: scene.motion_bounds(),
            triangles: scene.triangle_count(),
        })
    }

    /// Draws instance `i` at its transform in `scene` from the next recorded frame on (the
    /// same scene this one was made from, with instances moved).
    pub fn set_instance_transform(&mut self, scene: &Scene, i: usize) {
        self.instances[i] = instance_draw(scene, i);
    }

    /// Whether `draw` is of a delta material (see [`GpuScene::material_delta`]).
    pub fn is_delta(&self, draw: &Draw) -> bool {
        self.material_delta
            .get(draw.push.material.x as usize)
            .copied()
            .unwrap_or(false)
    }

    /// Every instance's draw with `clip_from_world` applied, where `origin` is subtracted
    /// from world positions first (in double precision): the eye pass passes the camera
    /// position and identity; shadow passes pass the camera position and the light's
    /// `clip_from_camera_relative` matrix.
    pub fn draws(&self, origin: DVec3, clip_from_relative: Option<DMat4>) -> Vec<Draw> {
        let to_relative = DMat4::from_translation(-origin);
        self.instances
            .iter()
            .enumerate()
            .map(|(instance, inst)| {
                let relative = to_relative * inst.transform;
                let model = match clip_from_relative {
                    Some(clip) => clip * relative,
                    None => relative,
                };
                let normal = glam::DMat3::from_mat4(inst.transform)
                    .inverse()
                    .transpose()
                    .as_mat3();
                Draw {
                    instance,
                    mesh: inst.mesh,
                    range: self.meshes[inst.mesh],
                    push: DrawPush {
                        model: model.as_mat4(),
                        normal0: normal.x_axis.extend(0.0),
                        normal1: normal.y_axis.extend(0.0),
                        normal2: normal.z_axis.extend(0.0),
                        material: UVec4::new(inst.material, 0, 0, 0),
                    },
                }
            })
            .collect()
    }
}
