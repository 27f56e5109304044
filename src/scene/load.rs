//! glTF 2.0 (`.gltf` / `.glb`) → [`Scene`].
//!
//! The loader reads the default scene (the `scene` property, else scene 0, else every root
//! node), flattens its node hierarchy into [`Instance`]s, converts each triangle primitive
//! into one [`Mesh`](super::Mesh) (`scene/gltf_mesh.rs`), each material into über-BSDF
//! parameters (`scene/gltf_material.rs`), KHR_lights_punctual lights into
//! radiometric [`Light`](super::Light)s ([`units`](super::units)) and perspective cameras into [`Camera`]s.
//! Animation channels (translation, rotation, scale; STEP, LINEAR, CUBICSPLINE) become
//! [`Clip`]s over the flattened node hierarchy ([`Animations`]), and an animated scene is
//! returned posed at t = 0 ([`Scene::pose_at`]).
//!
//! Material extensions: KHR_materials_unlit, KHR_materials_pbrSpecularGlossiness (converted to
//! metallic-roughness), KHR_materials_variants (the default mapping, or the variant
//! [`LoadOptions::variant`] names); KHR_materials_clearcoat and KHR_materials_sheen are accepted
//! and approximated by the base material (one warning). A scene with no nodes, or with no
//! triangles, is an empty scene (with a warning), not an error. [`LoadOptions::default_light`]
//! adds the default key light ([`default_light`](super::default_light)) to a scene with no light
//! and no emitter.
//!
//! Every error is one line that starts with the file's name. Input that can still be
//! rendered is repaired with a `log::warn!`; everything else is rejected. `docs/scenes.md`
//! lists which is which.

use super::gltf_data::{read_f32, split_glb, Buffers, MAX_VERTICES};
use super::gltf_light::{convert_camera, convert_light};
use super::gltf_material::{convert_material, TextureCache};
use super::gltf_mesh::convert_primitive;
use super::{
    Animations, Camera, Channel, Clip, Instance, Interpolation, LocalTransform, Material,
    MaterialId, MeshId, Property, RigNode, Sampler, Scene,
};
use anyhow::{anyhow, bail, ensure, Context, Result};
use glam::{Mat4, Quat, Vec3, Vec4};
use std::collections::{HashMap, HashSet};
use std::path::Path;

/// Extensions the loader understands; a file that *requires* any other is rejected.
pub const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_transmission",
    "KHR_materials_ior",
    "KHR_materials_specular",
    "KHR_materials_emissive_strength",
    "KHR_materials_unlit",
    "KHR_materials_pbrSpecularGlossiness",
    "KHR_materials_variants",
    "KHR_materials_clearcoat",
    "KHR_materials_sheen",
    "KHR_texture_transform",
];

/// Extensions accepted but approximated: the base material is rendered without them.
const APPROXIMATED_EXTENSIONS: &[&str] = &["KHR_materials_clearcoat", "KHR_materials_sheen"];

/// What the loader does beyond reading the file (the command line's scene flags).
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Add the default key light to a scene with no light and no emitter
    /// ([`Scene::add_default_light`]; `ispm` does unless `--no-default-light`).
    pub default_light: bool,
    /// KHR_materials_variants: show the variant of this name (`--variant`); `None`: the
    /// file's default materials. A name the file lacks is an error listing its variants.
    pub variant: Option<String>,
}

/// Deepest node hierarchy accepted (deeper is almost surely a cycle).
const MAX_NODE_DEPTH: usize = 256;
/// Most instances (node × mesh placements) accepted.
const MAX_INSTANCES: usize = 1 << 20;
/// Most keyframes one animation sampler may hold.
const MAX_KEYFRAMES: usize = 1 << 22;

/// Load a scene from a `.gltf` or `.glb` file, as the file says (no default light, default
/// material variant). External buffers and images are resolved relative to the file's
/// directory.
pub fn load(path: &Path) -> Result<Scene> {
    load_with(path, &LoadOptions::default())
}

/// [`load`] with [`LoadOptions`].
pub fn load_with(path: &Path, options: &LoadOptions) -> Result<Scene> {
    let name = path.display().to_string();
    let meta = std::fs::metadata(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => anyhow!("{name}: file not found"),
        _ => anyhow!("{name}: cannot read file: {e}"),
    })?;
    ensure!(!meta.is_dir(), "{name}: is a directory, not a glTF file");
    ensure!(
        meta.len() <= super::gltf_data::MAX_FILE_BYTES,
        "{name}: file is absurdly large ({} bytes)",
        meta.len()
    );
    let bytes = std::fs::read(path).map_err(|e| anyhow!("{name}: cannot read file: {e}"))?;
    let is_glb = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("glb"));
    if is_glb && !bytes.is_empty() && !bytes.starts_with(b"glTF") {
        bail!("{name}: not a GLB file (bad magic)");
    }
    load_from_slice_with(&bytes, &name, path.parent(), options)
}

/// Load a scene from the bytes of a `.gltf` (JSON) or `.glb` (binary) file, as the file says.
/// `name` appears in every error and warning; `base_dir` resolves external buffers and images
/// (`None`: the scene must be self-contained).
pub fn load_from_slice(bytes: &[u8], name: &str, base_dir: Option<&Path>) -> Result<Scene> {
    load_from_slice_with(bytes, name, base_dir, &LoadOptions::default())
}

/// [`load_from_slice`] with [`LoadOptions`].
pub fn load_from_slice_with(
    bytes: &[u8],
    name: &str,
    base_dir: Option<&Path>,
    options: &LoadOptions,
) -> Result<Scene> {
    let mut scene =
        load_inner(bytes, name, base_dir, options).map_err(|e| anyhow!("{name}: {e:#}"))?;
    if options.default_light {
        scene.add_default_light();
    }
    Ok(scene)
}

fn load_inner(
    bytes: &[u8],
    file: &str,
    base_dir: Option<&Path>,
    options: &LoadOptions,
) -> Result<Scene> {
    ensure!(!bytes.is_empty(), "file is empty");
    let (json, bin) = if bytes.starts_with(b"glTF") {
        let glb = split_glb(bytes)?;
        (glb.json, glb.bin)
    } else {
        (bytes, None)
    };
    let doc = parse_document(json)?;
    let approximated: Vec<&str> = doc
        .extensions_used()
        .filter(|e| APPROXIMATED_EXTENSIONS.contains(e))
        .collect();
    if !approximated.is_empty() {
        log::warn!(
            "{file}: {} approximated: the base material is rendered without the coat or sheen",
            approximated.join(", ")
        );
    }
    let variant = variant_index(&doc, options.variant.as_deref())?;
    let buffers = Buffers::resolve(&doc, bin, base_dir)?;
    let mut builder = Builder {
        file,
        variant,
        textures: TextureCache::new(&buffers, base_dir),
        buffers: &buffers,
        scene: Scene::default(),
        meshes_of: HashMap::new(),
        default_material: None,
        vertices: 0,
        targeted: targeted_nodes(&doc),
        rig: Animations::default(),
        occurrences: HashMap::new(),
    };
    builder.materials(&doc)?;
    builder.nodes(&doc)?;
    builder.animations(&doc)?;
    builder.finish()
}

/// Parses and validates the JSON; checks `extensionsRequired` against what we support.
fn parse_document(json: &[u8]) -> Result<gltf::Document> {
    use gltf::json::deserialize::from_slice;
    let mut root: gltf::json::Root = match from_slice(json) {
        Ok(root) => root,
        Err(e) => match with_scene_nodes(json) {
            Some(patched) => from_slice(&patched),
            None => Err(e),
        }
        .map_err(|e| anyhow!("malformed JSON: {e}"))?,
    };
    let unsupported: Vec<&str> = root
        .extensions_required
        .iter()
        .map(String::as_str)
        .filter(|e| !SUPPORTED_EXTENSIONS.contains(e))
        .collect();
    ensure!(
        unsupported.is_empty(),
        "requires unsupported extension(s): {}",
        unsupported.join(", ")
    );
    // Our own list is authoritative; the gltf crate's validator would reject some we handle.
    root.extensions_required.clear();
    // The validator checks neither an animation channel's target node nor its path (and the
    // gltf crate unwraps both).
    for (a, animation) in root.animations.iter().enumerate() {
        for (c, channel) in animation.channels.iter().enumerate() {
            let node = channel.target.node.value();
            ensure!(
                node < root.nodes.len(),
                "invalid glTF: animations[{a}].channels[{c}] targets node {node} of {}",
                root.nodes.len()
            );
            ensure!(
                !matches!(
                    channel.target.path,
                    gltf::json::validation::Checked::Invalid
                ),
                "invalid glTF: animations[{a}].channels[{c}].target.path is not translation, \
                 rotation, scale or weights"
            );
        }
    }
    // The validator indexes `accessors` with POSITION's index before checking it.
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            for index in prim.attributes.values() {
                ensure!(
                    index.value() < root.accessors.len(),
                    "invalid glTF: meshes[{m}].primitives[{p}] names accessor {} of {}",
                    index.value(),
                    root.accessors.len()
                );
            }
        }
    }
    check_variant_mappings(&root)?;
    use gltf::json::validation::{Error as Invalid, Validate};
    let mut errors = Vec::new();
    root.validate(&root, gltf::json::Path::new, &mut |path, err| {
        let p = path();
        // Lenient where the spec's strictness buys us nothing: POSITION min/max are unused.
        let unused = matches!(err, Invalid::Missing)
            && (p.as_str().ends_with(".min") || p.as_str().ends_with(".max"));
        if !unused {
            errors.push(format!("{p}: {err}"));
        }
    });
    if !errors.is_empty() {
        let more = match errors.len() {
            n if n > 3 => format!(" (+{} more)", n - 3),
            _ => String::new(),
        };
        errors.truncate(3);
        bail!("invalid glTF: {}{more}", errors.join("; "));
    }
    Ok(gltf::Document::from_json_without_validation(root))
}

/// The JSON with `"nodes": []` added to every scene without one, or `None` when none lacks it.
/// glTF makes a scene's `nodes` optional (an empty scene); the gltf crate requires it.
fn with_scene_nodes(json: &[u8]) -> Option<Vec<u8>> {
    let mut doc: serde_json::Value = serde_json::from_slice(json).ok()?;
    let mut patched = false;
    for scene in doc.get_mut("scenes")?.as_array_mut()? {
        if let Some(scene) = scene.as_object_mut() {
            if !scene.contains_key("nodes") {
                scene.insert("nodes".into(), serde_json::Value::Array(Vec::new()));
                patched = true;
            }
        }
    }
    patched.then(|| serde_json::to_vec(&doc).ok()).flatten()
}

/// KHR_materials_variants mappings name existing materials and variants (neither the validator
/// nor the gltf crate checks: it would silently show the default material).
fn check_variant_mappings(root: &gltf::json::Root) -> Result<()> {
    let variants = root
        .extensions
        .as_ref()
        .and_then(|e| e.khr_materials_variants.as_ref())
        .map_or(0, |v| v.variants.len());
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let mappings = prim
                .extensions
                .as_ref()
                .and_then(|e| e.khr_materials_variants.as_ref())
                .map_or(&[][..], |v| &v.mappings[..]);
            for (k, mapping) in mappings.iter().enumerate() {
                let at = format!("meshes[{m}].primitives[{p}] KHR_materials_variants mapping {k}");
                ensure!(
                    (mapping.material as usize) < root.materials.len(),
                    "invalid glTF: {at} names material {} of {}",
                    mapping.material,
                    root.materials.len()
                );
                if let Some(&v) = mapping.variants.iter().find(|&&v| v as usize >= variants) {
                    bail!("invalid glTF: {at} names variant {v} of {variants}");
                }
            }
        }
    }
    Ok(())
}

/// The index of the KHR_materials_variants variant named `wanted` (`None`: the default
/// materials); an unknown name is an error listing the file's variants.
fn variant_index(doc: &gltf::Document, wanted: Option<&str>) -> Result<Option<usize>> {
    let Some(wanted) = wanted else {
        return Ok(None);
    };
    let names: Vec<&str> = doc
        .variants()
        .map(|v| v.map(|v| v.name()).collect())
        .unwrap_or_default();
    match names.iter().position(|&n| n == wanted) {
        Some(i) => Ok(Some(i)),
        None if names.is_empty() => {
            bail!("no material variant {wanted:?}: the file has no material variants")
        }
        None => bail!(
            "no material variant {wanted:?} (the file's variants: {})",
            names.join(", ")
        ),
    }
}

struct Builder<'f, 'a, 'b> {
    file: &'f str,
    /// The KHR_materials_variants variant shown (`None`: the default materials).
    variant: Option<usize>,
    buffers: &'b Buffers<'a>,
    textures: TextureCache<'a, 'b>,
    scene: Scene,
    /// glTF mesh index → the [`MeshId`]s of its (kept) primitives.
    meshes_of: HashMap<usize, Vec<MeshId>>,
    default_material: Option<MaterialId>,
    vertices: usize,
    /// glTF nodes an animation channel targets (translation, rotation or scale).
    targeted: HashSet<usize>,
    /// The node occurrences visited so far and the node of every instance, light and camera.
    rig: Animations,
    /// glTF node index → its occurrences in `rig.nodes`.
    occurrences: HashMap<usize, Vec<usize>>,
}

/// The glTF nodes whose translation, rotation or scale some animation channel drives.
fn targeted_nodes(doc: &gltf::Document) -> HashSet<usize> {
    doc.animations()
        .flat_map(|a| a.channels().collect::<Vec<_>>())
        .filter(|c| c.target().property() != gltf::animation::Property::MorphTargetWeights)
        .map(|c| c.target().node().index())
        .collect()
}

impl Builder<'_, '_, '_> {
    fn materials(&mut self, doc: &gltf::Document) -> Result<()> {
        for mat in doc.materials() {
            let m = convert_material(self.file, &mat, &mut self.textures)?;
            self.scene.materials.push(m);
        }
        Ok(())
    }

    fn nodes(&mut self, doc: &gltf::Document) -> Result<()> {
        let roots: Vec<gltf::Node> = match doc.default_scene().or_else(|| doc.scenes().next()) {
            Some(scene) => scene.nodes().collect(),
            None => {
                let mut is_child = vec![false; doc.nodes().len()];
                for n in doc.nodes() {
                    for c in n.children() {
                        is_child[c.index()] = true;
                    }
                }
                doc.nodes().filter(|n| !is_child[n.index()]).collect()
            }
        };
        for node in roots {
            self.visit(&node, (Mat4::IDENTITY, None), 0)?;
        }
        Ok(())
    }

    /// Visits `node` below its parent's (world transform, occurrence).
    fn visit(
        &mut self,
        node: &gltf::Node,
        (parent, parent_node): (Mat4, Option<usize>),
        depth: usize,
    ) -> Result<()> {
        ensure!(
            depth < MAX_NODE_DEPTH,
            "node hierarchy deeper than {MAX_NODE_DEPTH} (cyclic?) at node {}",
            node.index()
        );
        let what = || format!("node {}", node_name(node));
        let targeted = self.targeted.contains(&node.index());
        let local = local_transform(node).with_context(what)?;
        ensure!(
            !(targeted && matches!(local, LocalTransform::Matrix(_))),
            "{}: is animated but has a matrix (glTF: animated nodes have translation, rotation \
             and scale)",
            what()
        );
        let world = parent * local.matrix(targeted);
        ensure!(world.is_finite(), "{}: world transform overflows", what());
        let occurrence = self.rig.nodes.len();
        let moves = targeted || parent_node.is_some_and(|p| self.rig.nodes[p].moves);
        self.rig.nodes.push(RigNode {
            name: node_name(node),
            parent: parent_node,
            local,
            targeted,
            moves,
        });
        self.occurrences
            .entry(node.index())
            .or_default()
            .push(occurrence);
        if let Some(mesh) = node.mesh() {
            let placed = self.instance(node, &mesh, world)?;
            let nodes = &mut self.rig.instance_nodes;
            nodes.extend(std::iter::repeat_n(occurrence, placed));
        }
        if let Some(light) = node.light() {
            if let Some(l) = convert_light(self.file, &light, world).with_context(what)? {
                self.scene.lights.push(l);
                self.rig.light_nodes.push(occurrence);
            }
        }
        if let Some(camera) = node.camera() {
            if let Some(c) = convert_camera(self.file, &camera, world).with_context(what)? {
                self.scene.cameras.push(c);
                self.rig.camera_nodes.push(occurrence);
            }
        }
        for child in node.children() {
            self.visit(&child, (world, Some(occurrence)), depth + 1)?;
        }
        Ok(())
    }

    /// Reads every animation's translation, rotation and scale channels that target a node of
    /// the scene (morph-target weights are skipped with a warning).
    fn animations(&mut self, doc: &gltf::Document) -> Result<()> {
        let mut warned_weights = false;
        for animation in doc.animations() {
            let name = animation
                .name()
                .map(str::to_owned)
                .unwrap_or_else(|| format!("#{}", animation.index()));
            let mut clip = Clip {
                name: name.clone(),
                channels: Vec::new(),
                duration: 0.0,
            };
            for channel in animation.channels() {
                use gltf::animation::Property as P;
                let property = match channel.target().property() {
                    P::Translation => Property::Translation,
                    P::Rotation => Property::Rotation,
                    P::Scale => Property::Scale,
                    P::MorphTargetWeights => {
                        if !warned_weights {
                            log::warn!(
                                "{}: animation {name}: morph-target weights are not supported; \
                                 those channels are ignored",
                                self.file
                            );
                            warned_weights = true;
                        }
                        continue;
                    }
                };
                let Some(nodes) = self.occurrences.get(&channel.target().node().index()) else {
                    continue; // a node outside the scene that is shown
                };
                let sampler = read_sampler(self.buffers, &channel.sampler(), property)
                    .with_context(|| {
                        format!(
                            "animation {name}: channel {} (sampler {})",
                            channel.index(),
                            channel.sampler().index()
                        )
                    })?;
                clip.duration = clip.duration.max(sampler.times[sampler.times.len() - 1]);
                for &node in nodes {
                    clip.channels.push(Channel {
                        node,
                        property,
                        sampler: sampler.clone(),
                    });
                }
            }
            if !clip.channels.is_empty() {
                self.rig.clips.push(clip);
            }
        }
        Ok(())
    }

    /// Places `mesh`'s primitives at `world`; returns how many instances it made.
    fn instance(&mut self, node: &gltf::Node, mesh: &gltf::Mesh, world: Mat4) -> Result<usize> {
        let det = world.determinant();
        if !(det.is_finite() && det.abs() > 1e-30) {
            log::warn!(
                "{}: node {}: transform is not invertible (zero scale?); instance skipped",
                self.file,
                node_name(node)
            );
            return Ok(0);
        }
        let ids = self.mesh_ids(mesh)?;
        let placed = ids.len();
        for id in ids {
            ensure!(
                self.scene.instances.len() < MAX_INSTANCES,
                "absurd size: more than {MAX_INSTANCES} instances"
            );
            self.scene.instances.push(Instance {
                name: node_name(node),
                mesh: id,
                transform: world,
            });
        }
        Ok(placed)
    }

    fn mesh_ids(&mut self, mesh: &gltf::Mesh) -> Result<Vec<MeshId>> {
        if let Some(ids) = self.meshes_of.get(&mesh.index()) {
            return Ok(ids.clone());
        }
        let mesh_name = mesh
            .name()
            .map(str::to_owned)
            .unwrap_or_else(|| format!("mesh{}", mesh.index()));
        let mut ids = Vec::new();
        for prim in mesh.primitives() {
            let name = format!("{mesh_name}/{}", prim.index());
            let variant = self.variant.and_then(|v| {
                prim.mappings()
                    .find(|m| m.variants().contains(&(v as u32)))
                    .and_then(|m| m.material().index())
            });
            let material = match variant.or(prim.material().index()) {
                Some(i) => i,
                None => self.default_material(),
            };
            let converted = convert_primitive(self.file, &name, &prim, self.buffers, material)
                .with_context(|| format!("mesh {name}"))?;
            if let Some(m) = converted {
                self.vertices += m.positions.len();
                ensure!(
                    self.vertices <= MAX_VERTICES,
                    "absurd size: more than {MAX_VERTICES} vertices in the scene"
                );
                ids.push(self.scene.meshes.len());
                self.scene.meshes.push(m);
            }
        }
        self.meshes_of.insert(mesh.index(), ids.clone());
        Ok(ids)
    }

    fn default_material(&mut self) -> MaterialId {
        *self.default_material.get_or_insert_with(|| {
            self.scene.materials.push(Material::default());
            self.scene.materials.len() - 1
        })
    }

    fn finish(mut self) -> Result<Scene> {
        if self.scene.instances.is_empty() {
            log::warn!(
                "{}: the scene has no triangle geometry: it renders empty (the background)",
                self.file
            );
        }
        self.scene.textures = std::mem::take(&mut self.textures.textures);
        if !self.rig.clips.is_empty() {
            // The rig is kept only for a scene that moves; it starts at t = 0.
            self.scene.animations = std::mem::take(&mut self.rig);
            let pose = self.scene.pose_at(0.0);
            self.scene.set_pose(&pose);
        }
        self.scene.camera = match self.scene.cameras.first() {
            Some(&c) => c,
            None => Camera::framing(self.scene.motion_bounds()),
        };
        Ok(self.scene)
    }
}

fn node_name(node: &gltf::Node) -> String {
    node.name()
        .map(str::to_owned)
        .unwrap_or_else(|| format!("#{}", node.index()))
}

/// The node's local transform, checked finite (matrix, or translation·rotation·scale with the
/// quaternion normalised).
fn local_transform(node: &gltf::Node) -> Result<LocalTransform> {
    match node.transform() {
        gltf::scene::Transform::Matrix { matrix } => {
            let m = Mat4::from_cols_array_2d(&matrix);
            ensure!(m.is_finite(), "non-finite number in matrix");
            Ok(LocalTransform::Matrix(m))
        }
        gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => {
            let t = Vec3::from_array(translation);
            let r = Quat::from_array(rotation);
            let s = Vec3::from_array(scale);
            ensure!(
                t.is_finite() && r.is_finite() && s.is_finite(),
                "non-finite number in translation/rotation/scale"
            );
            let len = r.length();
            ensure!(len > 1e-6, "rotation quaternion has zero length");
            Ok(LocalTransform::Trs {
                translation: t,
                rotation: r / len,
                scale: s,
            })
        }
    }
}

/// Reads and checks one animation sampler for `property`.
fn read_sampler(
    buffers: &super::gltf_data::Buffers,
    sampler: &gltf::animation::Sampler,
    property: Property,
) -> Result<Sampler> {
    use gltf::accessor::Dimensions;
    use gltf::animation::Interpolation as I;
    let interpolation = match sampler.interpolation() {
        I::Step => Interpolation::Step,
        I::Linear => Interpolation::Linear,
        I::CubicSpline => Interpolation::CubicSpline,
    };
    let times = read_f32(buffers, &sampler.input(), Dimensions::Scalar, MAX_KEYFRAMES)
        .context("keyframe times")?;
    ensure!(!times.is_empty(), "no keyframes");
    ensure!(
        times.iter().all(|t| t.is_finite() && *t >= 0.0),
        "keyframe times must be finite and ≥ 0"
    );
    if let Some(k) = times.windows(2).position(|w| w[0] >= w[1]) {
        bail!(
            "keyframe times must increase strictly ({} then {} at keys {k} and {})",
            times[k],
            times[k + 1],
            k + 1
        );
    }
    let rotation = property == Property::Rotation;
    let (dims, n) = if rotation {
        (Dimensions::Vec4, 4)
    } else {
        (Dimensions::Vec3, 3)
    };
    let per_key = if interpolation == Interpolation::CubicSpline {
        3
    } else {
        1
    };
    let raw = read_f32(buffers, &sampler.output(), dims, MAX_KEYFRAMES * per_key)
        .context("keyframe values")?;
    let count = raw.len() / n;
    ensure!(
        count == times.len() * per_key,
        "{count} keyframe values for {} keyframe times ({interpolation:?} needs {})",
        times.len(),
        times.len() * per_key
    );
    ensure!(
        raw.iter().all(|v| v.is_finite()),
        "non-finite keyframe value"
    );
    let mut values: Vec<Vec4> = raw
        .chunks_exact(n)
        .map(|c| Vec4::new(c[0], c[1], c[2], c.get(3).copied().unwrap_or(0.0)))
        .collect();
    if rotation {
        // The key values are unit quaternions; cubic-spline tangents are not.
        for k in 0..times.len() {
            let v = &mut values[k * per_key + per_key / 2];
            let len = v.length();
            ensure!(len > 1e-6, "rotation keyframe {k} is a zero quaternion");
            *v /= len;
        }
    }
    Ok(Sampler {
        interpolation,
        times,
        values,
    })
}
