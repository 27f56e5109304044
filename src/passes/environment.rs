//! Environment cube maps (graphics): the opaque scene rendered into the six faces of a cube from
//! each probe's centre, shaded forward with shadowed direct light plus emission
//! (`environment.frag`). The translucent pass reflects and refracts them.
//!
//! * One cube per probe: each delta-material instance is a probe centred on its own bounds
//!   (`plan/probes.rs` assigns them, at most `MAX_PROBES`), so two mirrors facing each
//!   other each see the room from where they stand, not from a point between them. Delta
//!   instances are not drawn into any cube.
//! * Cached: rendered on the first frame and again only after [`EnvironmentPass::invalidate`]
//!   (lights or instances moved; the cube holds radiance by world direction, so camera motion
//!   does not invalidate it).
//! * Direct light and emission only; the photons' indirect light (and caustics) seen from the
//!   same centre is a second, smaller cube that the CPU gathers from each frame's photon map
//!   (`photon_frame/environment.rs`) and the translucent pass adds to this one.
//!
//! ```text
//!   per probe:
//!   cube   RGBA16F, 6 layers (+X, −X, +Y, −Y, +Z, −Z), sampled as a cube
//!   depth  D32F, 6 layers, reversed-Z
//! ```

use super::eye_gbuffer::{draw_instances, material_texture_sets};
use crate::gpu::scene::{Draw, GpuScene};
use crate::gpu::{
    uses, vk, Attachment, Binding, Blend, Buffer, Cmd, Depth, DescriptorLayout, DescriptorSet,
    Filter, Gpu, GraphicsDesc, Image, ImageDesc, Load, Pipeline, Sampler, Use, ViewKind,
};
use crate::layout::{DrawPush, FrameUniforms, Vertex};
use crate::photon::bsdf::BsdfVariant;
use crate::timing::pass_id::PassId;
use glam::{Mat4, Vec3, Vec4};
use std::sync::Arc;

/// Texels per side of a cube face. A mirror low over a floor sees the floor from the cube's
/// centre at grazing angles, where one texel covers centimetres: at 128² the metal ring of
/// `caustic-ring` (centre 0.1 m above the floor) blended the lit floor inside the ring into its
/// reflection of the shadowed floor outside. 256² took its relMSE at 10k photons from 0.0314 to
/// 0.0238 at 640×480 and from 0.0331 to 0.0252 at 160×120 (512²: 0.0233; the other bundled
/// scenes unchanged, lavapipe, 2026-11-27). The cube is cached, so this costs nothing per frame
/// while lights and instances stand still; when they move it is rendered again every frame, 10.5
/// → 38.5 ms on lavapipe (docs/performance.md, "The environment cube's resolution").
pub const FACE_SIZE: u32 = 256;
pub const FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;
const DEPTH: vk::Format = vk::Format::D32_SFLOAT;

/// The lighting the environment shader reads (all but the per-face uniforms).
pub struct EnvironmentInputs<'a> {
    pub materials: &'a Buffer,
    pub lights: &'a Buffer,
    pub shadow_views: &'a Buffer,
    pub shadow_atlas: &'a Image,
}

pub struct EnvironmentPass {
    pipeline: Pipeline,
    _frame_layout: DescriptorLayout,
    _texture_layout: DescriptorLayout,
    /// One `FrameUniforms` per face, probe after probe (six a probe).
    faces: Vec<Buffer>,
    face_sets: Vec<DescriptorSet>,
    material_sets: Vec<DescriptorSet>,
    shadow: Sampler,
    /// Each probe's cube, and the depth it is rendered with.
    pub cubes: Vec<Image>,
    depths: Vec<Image>,
    dirty: bool,
}

/// Camera-relative world → clip of cube face `face` seen from camera-relative `centre`, with an
/// infinite reversed-Z projection (depth `near / distance along the face axis`). The rows follow
/// the cube-map face selection table of the Vulkan spec (major axis, s_c, t_c), so that the
/// texel a direction lands in when rendered is the texel a `samplerCube` lookup reads.
pub fn face_view_proj(face: usize, centre: Vec3, near: f32) -> Mat4 {
    let (major, s, t) = face_axes(face);
    let row = |a: Vec3| a.extend(-a.dot(centre));
    Mat4::from_cols(row(s), row(t), Vec4::new(0.0, 0.0, 0.0, near), row(major)).transpose()
}

/// Cube face `face`'s major axis and the directions its texel columns (s) and rows (t) grow
/// in: the Vulkan spec's face selection table.
fn face_axes(face: usize) -> (Vec3, Vec3, Vec3) {
    match face {
        0 => (Vec3::X, Vec3::NEG_Z, Vec3::NEG_Y),
        1 => (Vec3::NEG_X, Vec3::Z, Vec3::NEG_Y),
        2 => (Vec3::Y, Vec3::X, Vec3::Z),
        3 => (Vec3::NEG_Y, Vec3::X, Vec3::NEG_Z),
        4 => (Vec3::Z, Vec3::X, Vec3::NEG_Y),
        _ => (Vec3::NEG_Z, Vec3::NEG_X, Vec3::NEG_Y),
    }
}

/// The unit direction through the centre of texel (`x`, `y`) (column, row from the top) of
/// cube face `face`, `size` texels a side: where a `samplerCube` lookup reads that texel.
pub fn texel_direction(face: usize, x: u32, y: u32, size: u32) -> Vec3 {
    let (major, s, t) = face_axes(face);
    let at = |i: u32| 2.0 * (i as f32 + 0.5) / size as f32 - 1.0;
    (major + s * at(x) + t * at(y)).normalize()
}

impl EnvironmentPass {
    /// The pass for `probes` cubes, with the über-BSDF lobes of `variant` compiled into its
    /// forward shading.
    pub fn new(
        gpu: &Arc<Gpu>,
        scene: &GpuScene,
        inputs: &EnvironmentInputs,
        variant: BsdfVariant,
        probes: usize,
    ) -> anyhow::Result<Self> {
        assert!(
            probes > 0,
            "an environment pass renders at least one probe's cube"
        );
        let graphics = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        let (texture_layout, material_sets) =
            material_texture_sets(gpu, PassId::Environment.name(), scene)?;
        let shadow = Sampler::new(
            gpu,
            "environment.shadow_compare",
            Filter::LinearCompare,
            false,
        )?;
        let faces = (0..6 * probes)
            .map(|face| {
                Buffer::constants(
                    gpu,
                    &format!("environment.probe[{}].face[{}]", face / 6, face % 6),
                    size_of::<FrameUniforms>() as u64,
                    vk::BufferUsageFlags::UNIFORM_BUFFER,
                )
            })
            .collect::<Result<Vec<_>, _>>()?;
        let kinds = uses::kinds(&Self::uses(&faces[0], inputs, &shadow));
        let bindings = Binding::sequence(&kinds, graphics);
        let frame_layout =
            DescriptorLayout::new(gpu, "environment.frame", &bindings, faces.len() as u32)?;
        let face_sets = faces
            .iter()
            .map(|face| frame_layout.allocate(&uses::writes(&Self::uses(face, inputs, &shadow))))
            .collect::<Result<Vec<_>, _>>()?;
        let image = |name: &str, format, usage, view| {
            Image::planned(
                gpu,
                &ImageDesc {
                    name,
                    format,
                    width: FACE_SIZE,
                    height: FACE_SIZE,
                    layers: 6,
                    usage,
                    view,
                },
            )
        };
        // Each probe's cube and the depth it is rendered with.
        let (cubes, depths) = (0..probes)
            .map(|k| {
                let cube = image(
                    &format!("environment.probe[{k}].cube"),
                    FORMAT,
                    vk::ImageUsageFlags::COLOR_ATTACHMENT,
                    ViewKind::Cube,
                );
                let depth = image(
                    &format!("environment.probe[{k}].depth"),
                    DEPTH,
                    vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
                    ViewKind::D2Array,
                );
                (cube, depth)
            })
            .unzip();
        let attributes = super::vertex_attributes();
        let pipeline = Pipeline::graphics(
            gpu,
            &GraphicsDesc {
                name: PassId::Environment.name(),
                vertex: &crate::gpu::shader_table::EYE_GBUFFER_VERT,
                fragment: Some(&crate::gpu::shader_table::ENVIRONMENT_FRAG),
                vertex_stride: size_of::<Vertex>() as u32,
                vertex_attributes: &attributes,
                color_formats: &[FORMAT],
                blend: Blend::Off,
                depth: Some(Depth {
                    format: DEPTH,
                    test: true,
                    write: true,
                    compare: vk::CompareOp::GREATER,
                    bias: None,
                }),
                cull: vk::CullModeFlags::NONE,
                set_layouts: &[&frame_layout, &texture_layout],
                push_constant_size: size_of::<DrawPush>() as u32,
                specialization: &super::bsdf_constants(variant),
            },
        )?;
        Ok(Self {
            pipeline,
            _frame_layout: frame_layout,
            _texture_layout: texture_layout,
            faces,
            face_sets,
            material_sets,
            shadow,
            cubes,
            depths,
            dirty: true,
        })
    }

    /// What drawing face `face` (its uniforms) uses, in the shaders' binding order.
    fn uses<'a>(
        face: &'a Buffer,
        inputs: &EnvironmentInputs<'a>,
        shadow: &'a Sampler,
    ) -> [Use<'a>; 5] {
        [
            Use::Uniform(face),
            Use::Read(inputs.materials),
            Use::Read(inputs.lights),
            Use::Read(inputs.shadow_views),
            Use::Sampled(inputs.shadow_atlas, shadow),
        ]
    }

    /// Whether the next [`EnvironmentPass::record`] renders the cube.
    pub fn is_dirty(&self) -> bool {
        self.dirty
    }

    /// Makes the next frame render the cube again (after something in the scene moved).
    pub fn invalidate(&mut self) {
        self.dirty = true;
    }

    /// Records the face uniforms: the eye's `frame` with each face's projection and its probe's
    /// camera-relative centre (`centres`, one per probe) as the viewer. Clean cubes need
    /// nothing, so nothing is written.
    pub fn update(&self, cmd: &Cmd, frame: &FrameUniforms, centres: &[Vec3], near: f32) {
        if !self.dirty {
            return;
        }
        debug_assert_eq!(centres.len() * 6, self.faces.len());
        for (i, buffer) in self.faces.iter().enumerate() {
            let (centre, face) = (centres[i / 6], i % 6);
            let view_proj = face_view_proj(face, centre, near);
            let uniforms = FrameUniforms {
                view_proj,
                inv_view_proj: view_proj.inverse(),
                counts: frame.counts.with_z(FACE_SIZE).with_w(FACE_SIZE),
                viewer: centre.extend(1.0),
                ..*frame
            };
            cmd.update_buffer(buffer, 0, bytemuck::bytes_of(&uniforms));
        }
    }

    /// Renders every probe's six faces from `draws` (camera-relative, opaque instances only) if
    /// dirty;
    /// `inputs` are the ones the pass was created with (the shadow atlas already rendered
    /// this frame).
    pub fn record(
        &mut self,
        cmd: &Cmd,
        scene: &GpuScene,
        draws: &[Draw],
        inputs: &EnvironmentInputs,
    ) {
        if !self.dirty {
            return;
        }
        let _scope = cmd.scope(PassId::Environment.name());
        let uses: Vec<Use> = (self.faces.iter())
            .flat_map(|face| Self::uses(face, inputs, &self.shadow))
            .collect();
        for (i, set) in self.face_sets.iter().enumerate() {
            let (probe, face) = (i / 6, (i % 6) as u32);
            // The uses wait with the first face's attachments.
            let uses = if i == 0 { &uses[..] } else { &[] };
            cmd.begin_pass(
                uses,
                &[Attachment {
                    image: &self.cubes[probe],
                    layer: face,
                    load: Load::Clear([0.0, 0.0, 0.0, 1.0]),
                }],
                Some(&Attachment {
                    image: &self.depths[probe],
                    layer: face,
                    load: Load::Clear([0.0; 4]),
                }),
            );
            cmd.bind_pipeline(&self.pipeline);
            cmd.bind_sets(&self.pipeline, 0, &[*set]);
            draw_instances(cmd, &self.pipeline, scene, draws, &self.material_sets);
            cmd.end_rendering();
        }
        // The translucent pass's declared use of the cubes makes it wait for these faces.
        self.dirty = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Vulkan spec's cube-map face selection: face index and (s, t) in [0, 1] of `d`.
    fn spec_lookup(d: Vec3) -> (usize, f32, f32) {
        let a = d.abs();
        let (face, sc, tc, ma) = if a.x >= a.y && a.x >= a.z {
            if d.x > 0.0 {
                (0, -d.z, -d.y, a.x)
            } else {
                (1, d.z, -d.y, a.x)
            }
        } else if a.y >= a.z {
            if d.y > 0.0 {
                (2, d.x, d.z, a.y)
            } else {
                (3, d.x, -d.z, a.y)
            }
        } else if d.z > 0.0 {
            (4, d.x, -d.y, a.z)
        } else {
            (5, -d.x, -d.y, a.z)
        };
        (face, 0.5 * (sc / ma + 1.0), 0.5 * (tc / ma + 1.0))
    }

    #[test]
    fn a_texel_direction_looks_up_its_own_texel() {
        let size = 32;
        for face in 0..6 {
            for (x, y) in [(0, 0), (31, 0), (0, 31), (31, 31), (5, 17), (16, 16)] {
                let (f, s, t) = spec_lookup(texel_direction(face, x, y, size));
                let texel = ((s * size as f32) as u32, (t * size as f32) as u32);
                assert_eq!((f, texel), (face, (x, y)), "face {face} texel ({x}, {y})");
            }
        }
    }

    #[test]
    fn faces_render_where_a_cube_lookup_reads() {
        let centre = Vec3::new(0.3, -1.0, 2.0);
        let near = 0.01;
        let mut seed = 1u32;
        let mut next = || {
            seed = seed.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
            (seed >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0
        };
        for _ in 0..1000 {
            let d = Vec3::new(next(), next(), next());
            if d.length() < 1e-3 {
                continue;
            }
            let (face, s, t) = spec_lookup(d);
            let clip = face_view_proj(face, centre, near) * (centre + 3.0 * d).extend(1.0);
            assert!(clip.w > 0.0, "{d} is behind face {face}");
            // Framebuffer x grows with s, y (rows, top first) with t.
            let (x, y) = (0.5 * (clip.x / clip.w + 1.0), 0.5 * (clip.y / clip.w + 1.0));
            assert!(
                (x - s).abs() < 1e-4 && (y - t).abs() < 1e-4,
                "{d}: face {face} at ({x}, {y}), lookup reads ({s}, {t})"
            );
            let depth = clip.z / clip.w;
            assert!(depth > 0.0 && depth < 1.0, "reversed-Z depth {depth}");
        }
    }
}
