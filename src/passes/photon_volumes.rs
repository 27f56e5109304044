//! Photon volumes: the radiance estimate by scattering (paper §4). Every photon is drawn as an
//! instanced **billboard**, a quad that covers its kernel's projection; the fragment shader reads
//! the eye G-buffer at its pixel and adds f · Φ · κ into the HDR indirect buffer.
//!
//! ```text
//!            quad (⊥ to the eye ray through the centre, at distance d + R)
//!              |
//!   eye ·------+----- ← the kernel's bounding sphere (centre at d, radius R = r_xy)
//!        \  ( ● )|      half-size h = (d + R)·R / √(d² − R²): the tangent cone's
//!         \      |      cross-section there, so every pixel the sphere covers is covered
//! ```
//!
//! **Depth.** The quad lies at the sphere's far side: along any eye ray through the sphere it is
//! behind every point of the sphere (`dir·x` grows along the ray and the quad's plane is
//! `dir·x = d + R`). It is drawn with a reversed depth test (it passes where it lies *behind*
//! the visible surface), so each photon reaches each pixel it covers once, and surfaces behind
//! the whole plane are culled. When the eye is inside the bounding sphere the quad is the whole
//! screen at infinite depth (reversed-Z 0), so no dark blotch appears as the viewer approaches a
//! surface. As with the icosahedra it replaced, volumes in front of the surface are discarded by
//! the kernel test in the fragment shader.
//!
//! *Why a quad.* The icosahedron before it drew 20 triangles per photon: on lavapipe the pass was
//! then bound by per-triangle work, not by pixels (`--subsample 4`, 16× fewer pixels, made it
//! only 1.1–1.6× cheaper, docs/performance.md); the quad draws 2.
//!
//! The photon map may span several photon buffers (hard case "more photons than fit in one
//! buffer": one storage-buffer descriptor reaches `maxStorageBufferRange` bytes at most, 128 MiB
//! on lavapipe): the pass holds one descriptor set per buffer and draws each buffer's volumes
//! in turn, in photon order, so the sum is the same as from one buffer.
//!
//! At `--subsample N > 1` the same volumes are drawn at 1/N resolution with
//! `photon_volumes_subsampled.frag` into two low-resolution targets (irradiance-like Σ Φκ and
//! glossy radiance) for [`super::upsample`], without a depth attachment: the eye depth is full
//! resolution and a target's attachments must share its size, so the kernel test alone culls
//! (see `upsample.rs` for the trade-off and `docs/performance.md` for its cost).

use super::eye_gbuffer::{GBuffer, DEPTH};
use crate::gpu::{
    uses, vk, Access, Attachment, Binding, Blend, Buffer, Cmd, Depth, DescriptorLayout,
    DescriptorSet, Filter, Gpu, GraphicsDesc, Image, Load, Pipeline, Sampler, Use, VertexAttribute,
};
use crate::layout::shared_constants::{BILLBOARD_INSIDE, BILLBOARD_MARGIN};
use crate::photon::bsdf::BsdfVariant;
use crate::photon::kernel::{KernelSettings, Share};
use crate::timing::pass_id::PassId;
use std::sync::Arc;

pub const FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

/// The billboard's corners (`photon_volumes.vert` places them) and its two triangles.
pub fn billboard() -> (Vec<[f32; 3]>, Vec<u32>) {
    (
        vec![
            [-1.0, -1.0, 0.0],
            [1.0, -1.0, 0.0],
            [1.0, 1.0, 0.0],
            [-1.0, 1.0, 0.0],
        ],
        vec![0, 1, 2, 0, 2, 3],
    )
}

/// Half the side of the billboard of a bounding sphere of radius `r` whose centre lies `d` from
/// the eye, placed at distance `d + r` perpendicular to the ray through the centre: the tangent
/// cone's radius there (module docs). `None` when the eye is inside the sphere (the whole
/// screen). The GLSL twin is in `photon_volumes.vert`.
pub fn billboard_half_size(d: f32, r: f32) -> Option<f32> {
    (d > r * BILLBOARD_INSIDE).then(|| (d + r) * r / (d * d - r * r).sqrt() * BILLBOARD_MARGIN)
}

/// The push constants (`Push` in `photon_volumes.vert`; the fragment shaders declare the
/// scalars, not the offset).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    r_min: f32,
    r_max: f32,
    count: u32,
    subsample: u32,
    footprint: f32,
    footprint_max: f32,
    /// The kNN radii's factor ([`KernelSettings::scale`]).
    scale: f32,
    /// The largest glossy exponent the fragment stages evaluate
    /// ([`KernelSettings::gather_exponent_max`]).
    gather_exponent_max: f32,
    /// Added to every stored photon position to make it eye-relative (xyz; w unused): the
    /// photon map's origin minus the eye (`photon_frame.rs`).
    offset: [f32; 4],
    /// Which photons are drawn (`photon::kernel::Share::push`); the vertex stage collapses
    /// the others' billboards.
    share: u32,
    split: f32,
    pad: [u32; 2],
}
// std430 push-constant layout: the vec4 after eight scalars starts at byte 32.
const _: () = assert!(std::mem::offset_of!(Push, offset) == 32);
const _: () = assert!(std::mem::offset_of!(Push, share) == 48);
const _: () = assert!(size_of::<Push>() == 64);

/// The indirect-radiance target (alpha: number of volumes that touched the pixel). Planned,
/// as are the other targets below: the estimator that writes them and the passes that read
/// them add their uses (`gpu/image.rs`); this one is read back (`Renderer::read_indirect`).
pub fn target(gpu: &Arc<Gpu>, width: u32, height: u32) -> Image {
    super::planned_rgba32f(
        gpu,
        "indirect",
        (width, height),
        vk::ImageUsageFlags::TRANSFER_SRC,
    )
}

/// The two low-resolution targets of `--subsample N > 1`: `[irradiance, glossy]`.
pub fn low_targets(gpu: &Arc<Gpu>, width: u32, height: u32) -> [Image; 2] {
    let none = vk::ImageUsageFlags::empty();
    ["indirect.low_irradiance", "indirect.low_glossy"]
        .map(|name| super::planned_rgba32f(gpu, name, (width, height), none))
}

/// The global photons' share of the estimate beside the full-resolution [`target`] (or, at
/// `--subsample N > 1`, beside the [`low_targets`], at their size), for the support
/// normalisation (`passes/support.rs`): `[global, weight]`, global's RGB what the global photons
/// alone added and its alpha their `Σ κ·r`, weight's R their `Σ κ` (and at low resolution its
/// GBA their share of the glossy target).
pub fn support_targets(gpu: &Arc<Gpu>, width: u32, height: u32) -> [Image; 2] {
    let none = vk::ImageUsageFlags::empty();
    ["indirect.global", "indirect.global_weight"]
        .map(|name| super::planned_rgba32f(gpu, name, (width, height), none))
}

/// The most photon buffers one pass draws from (the descriptor pool's size). At lavapipe's
/// 128 MiB per buffer that is 179 million photons.
pub const MAX_PHOTON_BUFFERS: usize = 64;

/// What the photon volumes read.
pub struct PhotonVolumeInputs<'a> {
    pub frame: &'a Buffer,
    /// The photon map, split over one or more buffers (in photon order).
    pub photons: &'a [Buffer],
    pub materials: &'a Buffer,
    pub gbuffer: &'a GBuffer,
}

pub struct PhotonVolumesPass {
    pipeline: Pipeline,
    layout: DescriptorLayout,
    /// One set per photon buffer, grown by [`Self::rebind`].
    sets: Vec<DescriptorSet>,
    sampler: Sampler,
    vertices: Buffer,
    indices: Buffer,
    subsample: u32,
}

impl PhotonVolumesPass {
    /// The full-resolution pass at `subsample` 1, else the 1/`subsample` one, with the
    /// über-BSDF lobes of `variant` compiled in, drawing into `targets` (the images
    /// [`Self::record`] is given; their colour-attachment use is declared here).
    pub fn new(
        gpu: &Arc<Gpu>,
        inputs: &PhotonVolumeInputs,
        (subsample, targets): (u32, &[&Image]),
        variant: BsdfVariant,
    ) -> anyhow::Result<Self> {
        for target in targets {
            target.require(
                vk::ImageUsageFlags::COLOR_ATTACHMENT,
                "a photon volumes target",
            );
        }
        let graphics = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        let sampler = Sampler::new(gpu, "photon_volumes.nearest", Filter::Nearest, false)?;
        let uses = |photons| Self::uses(inputs, photons, &sampler);
        // The kinds are every buffer's (any buffer stands in before the first photons).
        let kinds = uses::kinds(&uses(inputs.photons.first().unwrap_or(inputs.materials)));
        let bindings = Binding::sequence(&kinds, graphics);
        let layout = DescriptorLayout::new(
            gpu,
            PassId::PhotonVolumes.name(),
            &bindings,
            MAX_PHOTON_BUFFERS as u32,
        )?;
        let sets = inputs
            .photons
            .iter()
            .map(|photons| layout.allocate(&uses::writes(&uses(photons))))
            .collect::<Result<Vec<_>, _>>()?;
        let (vertices, indices) = billboard();
        let vertices = gpu.upload_buffer(
            "photon_volumes.billboard.vertices",
            vk::BufferUsageFlags::VERTEX_BUFFER,
            bytemuck::cast_slice(&vertices),
            Access::VertexInput,
        )?;
        let indices = gpu.upload_buffer(
            "photon_volumes.billboard.indices",
            vk::BufferUsageFlags::INDEX_BUFFER,
            bytemuck::cast_slice(&indices),
            Access::IndexInput,
        )?;
        let subsample = subsample.max(1);
        let (fragment, color_formats, depth) = if subsample == 1 {
            (
                &crate::gpu::shader_table::PHOTON_VOLUMES_FRAG,
                &[FORMAT, FORMAT, FORMAT][..],
                Some(Depth {
                    format: DEPTH,
                    test: true,
                    write: false,
                    // Reversed-Z: passes where the back face is behind the stored surface.
                    compare: vk::CompareOp::LESS_OR_EQUAL,
                    bias: None,
                }),
            )
        } else {
            (
                &crate::gpu::shader_table::PHOTON_VOLUMES_SUBSAMPLED_FRAG,
                &[FORMAT, FORMAT, FORMAT, FORMAT][..],
                None,
            )
        };
        let pipeline = Pipeline::graphics(
            gpu,
            &GraphicsDesc {
                name: PassId::PhotonVolumes.name(),
                vertex: &crate::gpu::shader_table::PHOTON_VOLUMES_VERT,
                fragment: Some(fragment),
                vertex_stride: 12,
                vertex_attributes: &[VertexAttribute {
                    location: 0,
                    format: vk::Format::R32G32B32_SFLOAT,
                    offset: 0,
                }],
                color_formats,
                blend: Blend::Additive,
                depth,
                cull: vk::CullModeFlags::NONE,
                set_layouts: &[&layout],
                push_constant_size: size_of::<Push>() as u32,
                specialization: &super::bsdf_constants(variant),
            },
        )?;
        Ok(Self {
            pipeline,
            layout,
            sets,
            sampler,
            vertices,
            indices,
            subsample,
        })
    }

    /// What drawing from `photons` uses, in the shaders' binding order.
    fn uses<'a>(
        inputs: &PhotonVolumeInputs<'a>,
        photons: &'a Buffer,
        sampler: &'a Sampler,
    ) -> [Use<'a>; 7] {
        let g = inputs.gbuffer;
        [
            Use::Uniform(inputs.frame),
            Use::Read(photons),
            Use::Read(inputs.materials),
            Use::Sampled(&g.position, sampler),
            Use::Sampled(&g.normal, sampler),
            Use::Sampled(&g.albedo, sampler),
            Use::Sampled(&g.material, sampler),
        ]
    }

    /// Points the pass at new inputs (larger or more photon buffers), allocating a set for
    /// each new buffer. The GPU must be done with the previous frame.
    pub fn rebind(&mut self, inputs: &PhotonVolumeInputs) -> anyhow::Result<()> {
        anyhow::ensure!(
            inputs.photons.len() <= MAX_PHOTON_BUFFERS,
            "the photon map needs {} photon buffers, more than the {MAX_PHOTON_BUFFERS} the \
             photon volumes can draw from",
            inputs.photons.len()
        );
        for (i, photons) in inputs.photons.iter().enumerate() {
            let writes = uses::writes(&Self::uses(inputs, photons, &self.sampler));
            match self.sets.get(i) {
                Some(&set) => self.layout.update(set, &writes),
                None => self.sets.push(self.layout.allocate(&writes)?),
            }
        }
        Ok(())
    }

    /// Draws `counts[i]` photon volumes from photon buffer `i` (normals packed with their kNN
    /// radii, [`crate::photon::types::pack_normal`]) with the radii of `kernel` (its scale,
    /// clamp and footprint floor, [`crate::photon::kernel`]) into `targets`: `[indirect]` and
    /// the two [`support_targets`] at subsample 1, else the two [`low_targets`]. `offset` is added to every stored photon
    /// position to make it relative to the eye (the frame's space). Only the photons of `share`
    /// are drawn; with `add` (the fine photons at full resolution when subsampling,
    /// `render/photon_frame/estimate.rs`) they are added to what `targets[0]` holds.
    pub fn record(
        &self,
        cmd: &Cmd,
        inputs: &PhotonVolumeInputs,
        (counts, kernel, offset): (&[u32], &KernelSettings, glam::Vec3),
        (targets, share, add): (&[&Image], Share, bool),
    ) {
        let scope = match add {
            true => PassId::FinePhotons,
            false => PassId::PhotonVolumes,
        };
        let _scope = cmd.scope(scope.name());
        let drawn = || inputs.photons.iter().zip(&self.sets).zip(counts);
        // Only the drawn buffers: an undrawn photon buffer may belong to the transfer queue.
        let uses: Vec<Use> = drawn()
            .filter(|(_, &count)| count > 0)
            .flat_map(|((photons, _), _)| Self::uses(inputs, photons, &self.sampler))
            .collect();
        let colors: Vec<Attachment> = (targets.iter().enumerate())
            .map(|(i, &image)| Attachment {
                image,
                layer: 0,
                load: match add && i == 0 {
                    true => Load::Keep,
                    false => Load::Clear([0.0; 4]),
                },
            })
            .collect();
        let depth = Attachment {
            image: &inputs.gbuffer.depth,
            layer: 0,
            load: Load::Keep,
        };
        cmd.begin_pass(&uses, &colors, (self.subsample == 1).then_some(&depth));
        for ((_, &set), &count) in drawn() {
            if count == 0 {
                continue;
            }
            cmd.bind_pipeline(&self.pipeline);
            cmd.bind_sets(&self.pipeline, 0, &[set]);
            cmd.bind_vertex_buffer(&self.vertices);
            cmd.bind_index_buffer(&self.indices);
            cmd.push_constants(
                &self.pipeline,
                &Push {
                    r_min: kernel.r_min,
                    r_max: kernel.r_max,
                    count,
                    subsample: self.subsample,
                    footprint: kernel.footprint,
                    footprint_max: kernel.footprint_max,
                    scale: kernel.scale,
                    gather_exponent_max: kernel.gather_exponent_max(),
                    offset: offset.extend(0.0).to_array(),
                    share: share.push().0,
                    split: share.push().1,
                    pad: [0; 2],
                },
            );
            cmd.draw_indexed_instanced(6, count);
        }
        cmd.end_rendering();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn the_billboard_covers_the_projection_of_its_bounding_sphere() {
        // Rays from the eye (the origin) through points of the sphere meet the billboard's plane
        // within its half size, for spheres near and far, small and large, in any direction.
        let mut checked = 0;
        for (k, &(d, r)) in [
            (10.0f32, 0.1f32),
            (2.0, 1.0),
            (1.01, 1.0),
            (1.5, 1.4),
            (100.0, 3.0),
        ]
        .iter()
        .enumerate()
        {
            let dir = Vec3::new(0.3, -0.2 + 0.1 * k as f32, -1.0).normalize();
            let h = billboard_half_size(d, r).expect("the eye is outside");
            let (t, b) = dir.any_orthonormal_pair();
            for i in 0..64 {
                for j in 0..32 {
                    let phi = i as f32 / 64.0 * std::f32::consts::TAU;
                    let z = -1.0 + (j as f32 + 0.5) / 16.0;
                    let s = (1.0 - z * z).max(0.0).sqrt();
                    let p = dir * d + (t * (s * phi.cos()) + b * (s * phi.sin()) + dir * z) * r;
                    // The eye ray through p meets the plane dir·x = d + r at p·(d + r)/(dir·p).
                    let along = dir.dot(p);
                    assert!(along > 0.0, "a sphere point behind the eye");
                    let q = p * ((d + r) / along);
                    let offset = q - dir * (d + r);
                    assert!(
                        offset.dot(t).abs() <= h && offset.dot(b).abs() <= h,
                        "d {d}, r {r}: {p} meets the plane outside the billboard"
                    );
                    // And the billboard is behind the point along the ray.
                    assert!(q.length() >= p.length() - 1e-4 * d);
                    checked += 1;
                }
            }
        }
        assert_eq!(checked, 5 * 64 * 32);
        assert_eq!(billboard_half_size(1.0, 1.0), None, "the eye on the sphere");
        assert_eq!(billboard_half_size(0.5, 1.0), None, "the eye inside");
    }
}
