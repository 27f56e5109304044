//! Translucent and mirror surfaces (graphics): the delta-material instances (glass, perfect
//! mirrors), which the eye G-buffer leaves out, drawn forward over the finished opaque radiance
//! with the eye depth test. Each fragment is its material's shadowed direct light (non-delta
//! lobes) plus what arrives in the mirror and refracted directions, weighted by the über-BSDF's
//! own (Fresnel) lobe reflectances (`translucent.frag`): the ray first meets the object's own
//! surfaces, traced through a BVH of the mesh's triangles ([`object_bvh`]), then the
//! environment cube map. The nearest delta surface wins (depth writes), and it replaces what is
//! behind it: refraction reads the cube map, not the screen, so opaque surfaces seen through
//! glass appear as the cube map saw them (direct light and the photons' indirect light, from
//! the cube's centre). Each delta instance looks up the cubes of its probe (its own, while the
//! scene has at most `MAX_PROBES` delta instances): one descriptor set a probe, bound before
//! that probe's draws. Convex objects are drawn with a pipeline of their own, whose rays
//! leaving the object skip its traversal ([`object_bvh`], "Convex meshes").

pub mod object_bvh;

use super::eye_gbuffer::{draw_instances, material_texture_sets};
use crate::config::settings::SkippedPass;
use crate::gpu::scene::{Draw, GpuScene};
use crate::gpu::{
    uses, vk, Access, Attachment, Binding, Blend, Buffer, Cmd, Depth, DescriptorLayout,
    DescriptorSet, Filter, Gpu, GraphicsDesc, Image, Load, Pipeline, Sampler, SpecConstant, Use,
};
use crate::layout::shared_constants::SPEC_ID_CONVEX_SHORTCUT;
use crate::layout::{DrawPush, Vertex};
use crate::photon::bsdf::BsdfVariant;
use crate::scene::Scene;
use crate::timing::pass_id::PassId;
use glam::Vec3;
use object_bvh::ObjectBvhs;
use std::sync::Arc;

/// What the translucent shader reads.
pub struct TranslucentInputs<'a> {
    pub frame: &'a Buffer,
    pub materials: &'a Buffer,
    pub lights: &'a Buffer,
    pub shadow_views: &'a Buffer,
    pub shadow_atlas: &'a Image,
    /// One per probe.
    pub probes: Vec<ProbeInputs<'a>>,
}

/// What one probe's draws look their environment up in.
#[derive(Clone, Copy)]
pub struct ProbeInputs<'a> {
    /// `EnvironmentUniforms`.
    pub environment: &'a Buffer,
    pub map: &'a Image,
    /// The photons' indirect light seen from the same centre (`photon_frame/environment.rs`).
    pub indirect: &'a Image,
}

pub struct TranslucentPass {
    /// `[plain, convex]`: the pipeline for objects that are not convex, with the convex
    /// shortcut compiled out, and the one for convex objects, whose rays leaving the object
    /// through the face they start on skip its traversal (`translucent.frag`, `leaves_convex`).
    /// Each is made only when the scene has such an object. Either draws any object correctly
    /// (the shortcut needs the draw's `material.w` too); the other is the fallback.
    pipelines: [Option<Pipeline>; 2],
    /// The stats' entry for the delta meshes (of the scene's instances) drawn without the
    /// shortcut ([`convex_shortcut_skipped`]), made once.
    convex_skipped: Option<SkippedPass>,
    _layout: DescriptorLayout,
    _texture_layout: DescriptorLayout,
    /// One per probe.
    sets: Vec<DescriptorSet>,
    material_sets: Vec<DescriptorSet>,
    shadow: Sampler,
    linear: Sampler,
    /// The delta meshes' own triangles (`object_bvh`): nodes and triangles.
    object_nodes: Buffer,
    object_triangles: Buffer,
    /// Per scene mesh: 1 + its tree's root (0: not a delta mesh), and its centre when it is convex
    /// ([`object_bvh::convex_centre`]).
    object_roots: Vec<(u32, Option<Vec3>)>,
}

impl TranslucentPass {
    /// The pass with the über-BSDF lobes of `variant` compiled in (delta lobes must be on:
    /// they are what it draws), drawing over `radiance` with the eye's `depth` (the images
    /// [`Self::record`] is given; their attachment uses are declared here).
    pub fn new(
        gpu: &Arc<Gpu>,
        (scene, meshes): (&GpuScene, &Scene),
        inputs: &TranslucentInputs,
        (radiance, depth): (&Image, &Image),
        variant: BsdfVariant,
    ) -> anyhow::Result<Self> {
        radiance.require(
            vk::ImageUsageFlags::COLOR_ATTACHMENT,
            "the translucent pass's target",
        );
        depth.require(
            vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
            "the translucent pass's depth",
        );
        let (radiance_format, depth_format) = (radiance.format, depth.format);
        let graphics = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        let (texture_layout, material_sets) =
            material_texture_sets(gpu, PassId::Translucent.name(), scene)?;
        let shadow = Sampler::new(
            gpu,
            "translucent.shadow_compare",
            Filter::LinearCompare,
            false,
        )?;
        let linear = Sampler::new(gpu, "translucent.environment", Filter::Linear, false)?;
        let mut bvhs = ObjectBvhs::default();
        let object_roots: Vec<(u32, Option<Vec3>)> = meshes
            .meshes
            .iter()
            .map(|m| {
                let delta = scene.material_delta.get(m.material) == Some(&true);
                if delta && !m.triangles.is_empty() {
                    (bvhs.add(m) + 1, object_bvh::convex_centre(m))
                } else {
                    (0, None)
                }
            })
            .collect();
        if bvhs.nodes.is_empty() {
            // A scene drawn here has a delta mesh; an empty buffer cannot be bound.
            bvhs.nodes.push(Default::default());
            bvhs.triangles.push(Default::default());
        }
        let storage = |name, bytes| {
            gpu.upload_buffer(
                name,
                vk::BufferUsageFlags::STORAGE_BUFFER,
                bytes,
                Access::AnyShaderStorageRead,
            )
        };
        let object_nodes = storage(
            "translucent.object_nodes",
            bytemuck::cast_slice(&bvhs.nodes),
        )?;
        let object_triangles = storage(
            "translucent.object_triangles",
            bytemuck::cast_slice(&bvhs.triangles),
        )?;
        assert!(
            !inputs.probes.is_empty(),
            "the translucent pass looks up at least one probe"
        );
        let probe_uses = |probe| {
            Self::uses(
                inputs,
                probe,
                (&shadow, &linear),
                (&object_nodes, &object_triangles),
            )
        };
        let bindings = Binding::sequence(&uses::kinds(&probe_uses(&inputs.probes[0])), graphics);
        let count = inputs.probes.len() as u32;
        let layout = DescriptorLayout::new(gpu, PassId::Translucent.name(), &bindings, count)?;
        let sets = (inputs.probes.iter())
            .map(|probe| layout.allocate(&uses::writes(&probe_uses(probe))))
            .collect::<Result<Vec<_>, _>>()?;
        let attributes = super::vertex_attributes();
        let [glossy, delta] = super::bsdf_constants(variant);
        let pipeline = |convex: bool| {
            Pipeline::graphics(
                gpu,
                &GraphicsDesc {
                    name: if convex {
                        "translucent.convex"
                    } else {
                        PassId::Translucent.name()
                    },
                    vertex: &crate::gpu::shader_table::EYE_GBUFFER_VERT,
                    fragment: Some(&crate::gpu::shader_table::TRANSLUCENT_FRAG),
                    vertex_stride: size_of::<Vertex>() as u32,
                    vertex_attributes: &attributes,
                    color_formats: &[radiance_format],
                    blend: Blend::Off,
                    depth: Some(Depth {
                        format: depth_format,
                        test: true,
                        write: true,
                        compare: vk::CompareOp::GREATER,
                        bias: None,
                    }),
                    cull: vk::CullModeFlags::NONE,
                    set_layouts: &[&layout, &texture_layout],
                    push_constant_size: size_of::<DrawPush>() as u32,
                    specialization: &[
                        glossy,
                        delta,
                        SpecConstant::bool(SPEC_ID_CONVEX_SHORTCUT, convex),
                    ],
                },
            )
        };
        // Which kinds of delta object the scene's instances are: a scene without convex glass or
        // mirrors pays nothing for the shortcut, and one with only convex ones builds only its
        // pipeline.
        let mut delta_meshes: Vec<usize> = (meshes.instances.iter())
            .map(|inst| inst.mesh)
            .filter(|&m| object_roots.get(m).is_some_and(|(root, _)| *root != 0))
            .collect();
        delta_meshes.sort_unstable();
        delta_meshes.dedup();
        let [plain, convex] =
            pipelines_needed(delta_meshes.iter().map(|&m| object_roots[m].1.is_some()));
        let not_convex: Vec<String> = (delta_meshes.iter())
            .filter(|&&m| object_roots[m].1.is_none())
            .map(|&m| format!("'{}' (mesh {m})", meshes.meshes[m].name))
            .collect();
        let pipelines = [
            plain.then(|| pipeline(false)).transpose()?,
            convex.then(|| pipeline(true)).transpose()?,
        ];
        Ok(Self {
            pipelines,
            convex_skipped: convex_shortcut_skipped(&not_convex),
            _layout: layout,
            _texture_layout: texture_layout,
            sets,
            material_sets,
            shadow,
            linear,
            object_nodes,
            object_triangles,
            object_roots,
        })
    }

    /// The convex shortcut where it is compiled out, in the stats' form
    /// (`FrameStats::variants_skipped`; made once by `convex_shortcut_skipped`).
    pub fn variants_skipped(&self) -> Option<SkippedPass> {
        self.convex_skipped.clone()
    }

    /// What the pass uses with `probe`'s set, in the shaders' binding order.
    fn uses<'a>(
        inputs: &TranslucentInputs<'a>,
        probe: &ProbeInputs<'a>,
        (shadow, linear): (&'a Sampler, &'a Sampler),
        (object_nodes, object_triangles): (&'a Buffer, &'a Buffer),
    ) -> [Use<'a>; 10] {
        [
            Use::Uniform(inputs.frame),
            Use::Read(inputs.materials),
            Use::Read(inputs.lights),
            Use::Read(inputs.shadow_views),
            Use::Sampled(inputs.shadow_atlas, shadow),
            Use::Uniform(probe.environment),
            Use::Sampled(probe.map, linear),
            Use::Sampled(probe.indirect, linear),
            Use::Read(object_nodes),
            Use::Read(object_triangles),
        ]
    }

    /// Draws `draws` (camera-relative, delta instances only) over `radiance`, depth-tested
    /// against (and writing) the eye G-buffer's `depth`, each with its instance's probe
    /// (`probe_of[draw.instance]`). `inputs` are the ones the pass was created with.
    pub fn record(
        &self,
        cmd: &Cmd,
        (scene, draws, probe_of): (&GpuScene, &[Draw], &[usize]),
        inputs: &TranslucentInputs,
        depth: &mut Image,
        radiance: &mut Image,
    ) {
        let _scope = cmd.scope(PassId::Translucent.name());
        let uses: Vec<Use> = (inputs.probes.iter())
            .flat_map(|probe| {
                Self::uses(
                    inputs,
                    probe,
                    (&self.shadow, &self.linear),
                    (&self.object_nodes, &self.object_triangles),
                )
            })
            .collect();
        // Each draw's tree (`DrawPush::material.z`), and the draws grouped by probe (in draw
        // order within a probe), one set bound per group.
        let probe = |d: &Draw| probe_of.get(d.instance).copied().unwrap_or(0);
        let mut draws: Vec<Draw> = draws
            .iter()
            .map(|d| {
                let mut d = *d;
                let (root, centre) = self.object_roots.get(d.mesh).copied().unwrap_or_default();
                d.push.material.z = root;
                if let Some(c) = centre {
                    d.push.material.w = 1;
                    d.push.normal0.w = c.x;
                    d.push.normal1.w = c.y;
                    d.push.normal2.w = c.z;
                }
                d
            })
            .collect();
        // Convex or not (`material.w`): which pipeline draws it.
        let convex = |d: &Draw| d.push.material.w != 0;
        draws.sort_by_key(|d| (probe(d), convex(d)));
        cmd.begin_pass(
            &uses,
            &[Attachment {
                image: radiance,
                layer: 0,
                load: Load::Keep,
            }],
            Some(&Attachment {
                image: depth,
                layer: 0,
                load: Load::Keep,
            }),
        );
        debug_assert!(
            (draws.iter()).all(|d| probe_of
                .get(d.instance)
                .is_some_and(|&k| k < self.sets.len())),
            "every draw has a probe"
        );
        for group in draws.chunk_by(|a, b| (probe(a), convex(a)) == (probe(b), convex(b))) {
            let made = self.pipelines.each_ref().map(Option::is_some);
            let Some(pipeline) = &self.pipelines[pipeline_for(made, convex(&group[0]))] else {
                unreachable!("`pipelines_needed` asks for at least one pipeline")
            };
            cmd.bind_pipeline(pipeline);
            cmd.bind_sets(pipeline, 0, &[self.sets[probe(&group[0])]]);
            draw_instances(cmd, pipeline, scene, group, &self.material_sets);
        }
        cmd.end_rendering();
    }
}

/// The convex shortcut where it is compiled out, in the stats' form: the glass and mirror meshes
/// not known to be convex ([`object_bvh::convex_centre`]: not convex, flat, or too large to
/// check), `names` as `'name' (mesh i)` (names need not be unique); `None` when there are none.
fn convex_shortcut_skipped(names: &[String]) -> Option<SkippedPass> {
    let listed: Vec<&str> = names.iter().take(3).map(String::as_str).collect();
    let more = match names.len().saturating_sub(listed.len()) {
        0 => String::new(),
        n => format!(" and {n} more"),
    };
    let (noun, verb, them, its) = if names.len() == 1 {
        ("mesh", "is", "it", "its")
    } else {
        ("meshes", "are", "them", "their")
    };
    (!names.is_empty()).then(|| SkippedPass {
        name: "convex_shortcut".to_string(),
        reason: format!(
            "glass or mirror {noun} {}{more} {verb} not known to be convex (not convex, flat, \
             or too large to check): rays leaving {them} always traverse {its} triangles",
            listed.join(", ")
        ),
    })
}

/// Which of the pass's pipelines (`[plain, convex]`) a scene needs, from whether each of its
/// delta instances' meshes is convex: those of the kinds it has, and the plain one when it has
/// none.
fn pipelines_needed(convex: impl IntoIterator<Item = bool>) -> [bool; 2] {
    let mut kinds = [false; 2];
    for c in convex {
        kinds[usize::from(c)] = true;
    }
    if kinds == [false; 2] {
        kinds[0] = true;
    }
    kinds
}

/// The pipeline (an index into `[plain, convex]`) that draws a convex (or other) object, of
/// those `made`: its own kind's when made, else the other (either draws any object correctly:
/// the shortcut also needs the draw's `material.w`).
fn pipeline_for(made: [bool; 2], convex: bool) -> usize {
    let own = usize::from(convex);
    if made[own] {
        own
    } else {
        1 - own
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_scene_builds_the_pipelines_of_the_kinds_of_delta_object_it_has() {
        assert_eq!(pipelines_needed([true, true]), [false, true], "convex only");
        assert_eq!(pipelines_needed([false]), [true, false], "not convex only");
        assert_eq!(pipelines_needed([true, false, true]), [true, true], "both");
        assert_eq!(pipelines_needed([]), [true, false], "none: the plain one");
    }

    #[test]
    fn the_stats_name_the_meshes_without_the_shortcut_three_at_most() {
        assert_eq!(convex_shortcut_skipped(&[]), None);
        let names = |n: usize| {
            (0..n)
                .map(|i| format!("'m' (mesh {i})"))
                .collect::<Vec<_>>()
        };
        let one = convex_shortcut_skipped(&names(1)).expect("one mesh").reason;
        assert!(
            one.starts_with("glass or mirror mesh 'm' (mesh 0) is not"),
            "{one}"
        );
        assert!(
            one.ends_with("rays leaving it always traverse its triangles"),
            "{one}"
        );
        let five = convex_shortcut_skipped(&names(5))
            .expect("five meshes")
            .reason;
        assert!(
            five.contains("(mesh 2) and 2 more are not") && !five.contains("(mesh 3)"),
            "{five}"
        );
    }

    #[test]
    fn each_draw_takes_its_own_kinds_pipeline_and_falls_back_on_the_other() {
        assert_eq!(pipeline_for([true, true], true), 1);
        assert_eq!(pipeline_for([true, true], false), 0);
        assert_eq!(pipeline_for([false, true], true), 1);
        assert_eq!(pipeline_for([true, false], false), 0);
        // Only when its own was not made (`pipelines_needed` makes both kinds a scene has).
        assert_eq!(pipeline_for([true, false], true), 0);
        assert_eq!(pipeline_for([false, true], false), 1);
    }
}
