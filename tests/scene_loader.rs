//! glTF loader: every exporter layout we support, every repair, every rejection.
//!
//! Fixtures are built here, in code, and written into temporary directories.
// glTF fixtures spell rotations as JSON quaternion literals such as 0.7071068.
#![allow(clippy::approx_constant)]

use glam::{Mat4, Vec3};
use ispm::scene::load::{load, load_from_slice};
use ispm::scene::{LightKind, Scene};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

const FLOAT: u32 = 5126;
const U8: u32 = 5121;
const U16: u32 = 5123;
const U32: u32 = 5125;

/// A glTF document under construction with one binary buffer.
struct Fixture {
    doc: Value,
    bin: Vec<u8>,
}

fn f32_bytes(v: &[[f32; 3]]) -> Vec<u8> {
    v.iter().flatten().flat_map(|f| f.to_le_bytes()).collect()
}

const TRI: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
const UP: [[f32; 3]; 3] = [[0.0, 0.0, 1.0]; 3];

impl Fixture {
    fn empty() -> Self {
        Self {
            doc: json!({
                "asset": {"version": "2.0"},
                "scene": 0,
                "scenes": [{"nodes": [0]}],
                "nodes": [{"mesh": 0}],
                "meshes": [{"primitives": [{"attributes": {}}]}],
                "accessors": [], "bufferViews": [], "buffers": [],
            }),
            bin: Vec::new(),
        }
    }

    /// One triangle in the z = 0 plane facing +Z, with normals and u16 indices.
    fn triangle() -> Self {
        let mut f = Self::empty();
        let pos = f.vec3(&TRI);
        let nrm = f.vec3(&UP);
        let idx = f.indices(U16, &[0, 1, 2]);
        f.doc["meshes"][0]["primitives"][0] =
            json!({"attributes": {"POSITION": pos, "NORMAL": nrm}, "indices": idx});
        f
    }

    fn view(&mut self, bytes: &[u8], stride: Option<usize>) -> usize {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        let mut v = json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()});
        if let Some(s) = stride {
            v["byteStride"] = json!(s);
        }
        self.bin.extend_from_slice(bytes);
        push(&mut self.doc["bufferViews"], v)
    }

    fn accessor(&mut self, a: Value) -> usize {
        push(&mut self.doc["accessors"], a)
    }

    fn vec3(&mut self, v: &[[f32; 3]]) -> usize {
        let view = self.view(&f32_bytes(v), None);
        self.accessor(
            json!({"bufferView": view, "componentType": FLOAT, "count": v.len(), "type": "VEC3",
            "min": [-1e9, -1e9, -1e9], "max": [1e9, 1e9, 1e9]}),
        )
    }

    fn indices(&mut self, ty: u32, idx: &[u32]) -> usize {
        let bytes: Vec<u8> = match ty {
            U8 => idx.iter().map(|&i| i as u8).collect(),
            U16 => idx.iter().flat_map(|&i| (i as u16).to_le_bytes()).collect(),
            _ => idx.iter().flat_map(|&i| i.to_le_bytes()).collect(),
        };
        let view = self.view(&bytes, None);
        self.accessor(
            json!({"bufferView": view, "componentType": ty, "count": idx.len(), "type": "SCALAR"}),
        )
    }

    fn primitive(&mut self) -> &mut Value {
        &mut self.doc["meshes"][0]["primitives"][0]
    }

    fn with_buffer(&self, uri: Option<String>) -> Value {
        let mut doc = self.doc.clone();
        let mut buffer = json!({"byteLength": self.bin.len()});
        if let Some(u) = uri {
            buffer["uri"] = json!(u);
        }
        doc["buffers"] = json!([buffer]);
        doc
    }

    /// `.gltf` text with the buffer as a base64 data URI.
    fn data_uri(&self) -> Vec<u8> {
        let uri = format!("data:application/octet-stream;base64,{}", base64(&self.bin));
        self.with_buffer(Some(uri)).to_string().into_bytes()
    }

    /// `.glb` bytes with the buffer in the BIN chunk.
    fn glb(&self) -> Vec<u8> {
        let mut json = self.with_buffer(None).to_string().into_bytes();
        while json.len() % 4 != 0 {
            json.push(b' ');
        }
        let mut bin = self.bin.clone();
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
        let total = 12 + 8 + json.len() + 8 + bin.len();
        let mut out = b"glTF".to_vec();
        out.extend(2u32.to_le_bytes());
        out.extend((total as u32).to_le_bytes());
        out.extend((json.len() as u32).to_le_bytes());
        out.extend(b"JSON");
        out.extend(json);
        out.extend((bin.len() as u32).to_le_bytes());
        out.extend(b"BIN\0");
        out.extend(bin);
        out
    }

    /// Writes `name.gltf` and `name.bin` into `dir`; returns the `.gltf` path.
    fn write_with_bin(&self, dir: &Path, name: &str) -> PathBuf {
        std::fs::write(dir.join(format!("{name}.bin")), &self.bin).unwrap();
        let path = dir.join(format!("{name}.gltf"));
        let doc = self.with_buffer(Some(format!("{name}.bin")));
        std::fs::write(&path, doc.to_string()).unwrap();
        path
    }

    fn load(&self) -> anyhow::Result<Scene> {
        load_from_slice(&self.data_uri(), "fixture.gltf", None)
    }
}

fn push(array: &mut Value, v: Value) -> usize {
    let a = array.as_array_mut().unwrap();
    a.push(v);
    a.len() - 1
}

fn base64(bytes: &[u8]) -> String {
    const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                s.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// Asserts `r` is an error whose one-line message names `file` and contains `word`.
fn assert_error(r: anyhow::Result<Scene>, file: &str, word: &str) {
    match r {
        Ok(_) => panic!("expected an error mentioning {word:?}"),
        Err(e) => {
            let msg = format!("{e:#}");
            assert!(msg.contains(file), "{msg:?} does not name {file:?}");
            assert!(
                msg.to_lowercase().contains(&word.to_lowercase()),
                "{msg:?} lacks {word:?}"
            );
            assert!(!msg.contains('\n'), "{msg:?} is not one line");
            assert_eq!(
                format!("{e}"),
                msg,
                "the message must not hide in the error chain"
            );
        }
    }
}

fn assert_invariants(scene: &Scene) {
    for m in &scene.meshes {
        assert_eq!(m.normals.len(), m.positions.len());
        assert_eq!(m.uvs.len(), m.positions.len());
        for t in &m.triangles {
            assert!(t.iter().all(|&i| (i as usize) < m.positions.len()));
        }
        assert!(m.positions.iter().all(|p| p.is_finite()));
        assert!(m.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-5));
        assert!(m.material < scene.materials.len());
    }
}

// ---- bad input ---------------------------------------------------------------------------

#[test]
fn missing_file_is_an_error_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    assert_error(load(&dir.path().join("nope.glb")), "nope.glb", "not found");
}

#[test]
fn directory_is_an_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let sub = dir.path().join("scene.gltf");
    std::fs::create_dir(&sub).unwrap();
    assert_error(load(&sub), "scene.gltf", "directory");
}

#[test]
fn empty_file_is_an_error_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("empty.glb");
    std::fs::write(&path, b"").unwrap();
    assert_error(load(&path), "empty.glb", "empty");
}

#[test]
fn malformed_json_is_an_error_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("broken.gltf");
    std::fs::write(&path, b"{\"asset\": {\"version\": \"2.0\"}, \"nodes\": [").unwrap();
    assert_error(load(&path), "broken.gltf", "malformed JSON");
}

#[test]
fn truncated_glb_is_an_error_naming_the_file() {
    let glb = Fixture::triangle().glb();
    let dir = tempfile::tempdir().unwrap();
    for cut in [4, 11, 20, glb.len() / 2, glb.len() - 1] {
        let path = dir.path().join("cut.glb");
        std::fs::write(&path, &glb[..cut]).unwrap();
        assert_error(load(&path), "cut.glb", "truncated");
    }
}

#[test]
fn glb_with_bad_magic_is_an_error_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("fake.glb");
    std::fs::write(&path, b"PK\x03\x04 definitely a zip").unwrap();
    assert_error(load(&path), "fake.glb", "magic");
}

#[test]
fn out_of_range_index_is_an_error() {
    let mut f = Fixture::triangle();
    let idx = f.indices(U16, &[0, 1, 7]);
    f.primitive()["indices"] = json!(idx);
    assert_error(f.load(), "fixture.gltf", "out of range");
}

#[test]
fn accessor_past_buffer_end_is_an_error() {
    let mut f = Fixture::triangle();
    f.doc["accessors"][0]["count"] = json!(1000);
    f.doc["accessors"][1]["count"] = json!(1000);
    assert_error(f.load(), "fixture.gltf", "past the end");
    let mut f = Fixture::triangle();
    f.doc["bufferViews"][0]["byteLength"] = json!(1 << 20);
    assert_error(f.load(), "fixture.gltf", "out of bounds");
}

#[test]
fn nan_in_positions_is_an_error() {
    let mut f = Fixture::empty();
    let pos = f.vec3(&[[0.0, 0.0, 0.0], [f32::NAN, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    *f.primitive() = json!({"attributes": {"POSITION": pos}});
    assert_error(f.load(), "fixture.gltf", "non-finite");
}

#[test]
fn non_finite_node_matrix_is_an_error() {
    let mut f = Fixture::triangle();
    // 1e39 overflows f32: JSON's only way to spell infinity.
    f.doc["nodes"][0]["matrix"] = json!([1e39, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]);
    assert_error(f.load(), "fixture.gltf", "non-finite");
    let mut f = Fixture::triangle();
    f.doc["nodes"][0]["translation"] = json!([0, -1e39, 0]);
    assert_error(f.load(), "fixture.gltf", "non-finite");
}

#[test]
fn absurd_accessor_count_is_rejected_before_allocating() {
    let mut f = Fixture::triangle();
    // A sparse accessor needs no bufferView: only its count says how much to allocate.
    let idx_view = f.view(&[0u8; 4], None);
    let val_view = f.view(&[0u8; 12], None);
    let huge = f.accessor(
        json!({"componentType": FLOAT, "count": 1u64 << 31, "type": "VEC3",
        "min": [0, 0, 0], "max": [0, 0, 0],
        "sparse": {"count": 1, "indices": {"bufferView": idx_view, "componentType": U8},
                   "values": {"bufferView": val_view}}}),
    );
    f.primitive()["attributes"]["POSITION"] = json!(huge);
    f.primitive()["attributes"]
        .as_object_mut()
        .unwrap()
        .remove("NORMAL");
    f.primitive().as_object_mut().unwrap().remove("indices");
    assert_error(f.load(), "fixture.gltf", "absurd");
}

#[test]
fn unsupported_required_extension_is_an_error_listing_it() {
    let mut f = Fixture::triangle();
    f.doc["extensionsRequired"] = json!([
        "KHR_lights_punctual",
        "KHR_draco_mesh_compression",
        "EXT_meshopt_compression"
    ]);
    f.doc["extensionsUsed"] = f.doc["extensionsRequired"].clone();
    let err = format!("{:#}", f.load().unwrap_err());
    assert!(
        err.contains("fixture.gltf") && err.contains("unsupported"),
        "{err}"
    );
    assert!(
        err.contains("KHR_draco_mesh_compression") && err.contains("EXT_meshopt_compression"),
        "{err}"
    );
    assert!(!err.contains("KHR_lights_punctual"), "{err}");
}

#[test]
fn missing_bin_beside_gltf_is_an_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let path = Fixture::triangle().write_with_bin(dir.path(), "scene");
    std::fs::remove_file(dir.path().join("scene.bin")).unwrap();
    assert_error(load(&path), "scene.gltf", "missing file");
    assert_error(load(&path), "scene.gltf", "scene.bin");
}

#[test]
fn float_indices_are_a_bad_component_type() {
    let mut f = Fixture::triangle();
    let view = f.view(&f32_bytes(&[[0.0, 1.0, 2.0]]), None);
    let idx = f.accessor(
        json!({"bufferView": view, "componentType": FLOAT, "count": 3, "type": "SCALAR"}),
    );
    f.primitive()["indices"] = json!(idx);
    assert_error(f.load(), "fixture.gltf", "component type");
}

#[test]
fn unknown_component_type_is_an_error() {
    let mut f = Fixture::triangle();
    f.doc["accessors"][0]["componentType"] = json!(5130);
    assert_error(f.load(), "fixture.gltf", "invalid glTF");
}

#[test]
fn scene_without_geometry_is_an_empty_scene() {
    let mut f = Fixture::triangle();
    f.doc["nodes"] = json!([{"name": "empty"}]);
    let s = f.load().expect("an empty scene loads");
    assert!(s.instances.is_empty() && s.triangle_count() == 0);
    assert!(s.camera.position().is_finite());
}

#[test]
fn non_finite_light_intensity_is_an_error() {
    let mut f = Fixture::triangle();
    f.doc["extensions"] =
        json!({"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 1e39}]}});
    push(
        &mut f.doc["nodes"],
        json!({"extensions": {"KHR_lights_punctual": {"light": 0}}}),
    );
    f.doc["scenes"][0]["nodes"] = json!([0, 1]);
    assert_error(f.load(), "fixture.gltf", "non-finite");
}

#[test]
fn non_finite_material_value_is_an_error() {
    let mut f = Fixture::triangle();
    f.doc["materials"] = json!([{"pbrMetallicRoughness": {"roughnessFactor": 1e39}}]);
    f.primitive()["material"] = json!(0);
    assert_error(f.load(), "fixture.gltf", "non-finite");
}

#[test]
fn absurd_spot_cone_is_an_error() {
    let mut f = Fixture::triangle();
    f.doc["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"type": "spot", "intensity": 10, "spot": {"innerConeAngle": 0.1, "outerConeAngle": 3.0}}]}});
    push(
        &mut f.doc["nodes"],
        json!({"extensions": {"KHR_lights_punctual": {"light": 0}}}),
    );
    f.doc["scenes"][0]["nodes"] = json!([0, 1]);
    assert_error(f.load(), "fixture.gltf", "cone");
}

#[test]
fn cyclic_node_hierarchy_is_an_error_not_a_stack_overflow() {
    let mut f = Fixture::triangle();
    f.doc["nodes"] = json!([{"mesh": 0, "children": [1]}, {"children": [0]}]);
    assert_error(f.load(), "fixture.gltf", "cyclic");
}

// ---- layouts -----------------------------------------------------------------------------

#[test]
fn data_uri_bin_file_and_glb_layouts_load_the_same_scene() {
    let f = Fixture::triangle();
    let a = f.load().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let b = load(&f.write_with_bin(dir.path(), "tri")).unwrap();
    let glb = dir.path().join("tri.glb");
    std::fs::write(&glb, f.glb()).unwrap();
    let c = load(&glb).unwrap();
    assert_eq!(a.meshes, b.meshes);
    assert_eq!(a.meshes, c.meshes);
    assert_eq!(a.meshes[0].triangles, vec![[0, 1, 2]]);
    assert_invariants(&a);
}

#[test]
fn percent_encoded_bin_name_resolves() {
    let f = Fixture::triangle();
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("my mesh.bin"), &f.bin).unwrap();
    let doc = f.with_buffer(Some("my%20mesh.bin".into()));
    let path = dir.path().join("x.gltf");
    std::fs::write(&path, doc.to_string()).unwrap();
    assert_eq!(load(&path).unwrap().meshes.len(), 1);
}

#[test]
fn interleaved_attributes_load() {
    let mut f = Fixture::empty();
    let mut bytes = Vec::new();
    for (p, n) in TRI.iter().zip(UP.iter()) {
        bytes.extend(f32_bytes(&[*p, *n]));
    }
    let view = f.view(&bytes, Some(24));
    let pos = f.accessor(json!({"bufferView": view, "byteOffset": 0, "componentType": FLOAT, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}));
    let nrm = f.accessor(json!({"bufferView": view, "byteOffset": 12, "componentType": FLOAT, "count": 3, "type": "VEC3"}));
    *f.primitive() = json!({"attributes": {"POSITION": pos, "NORMAL": nrm}});
    let s = f.load().unwrap();
    let m = &s.meshes[0];
    assert_eq!(m.positions[1], Vec3::X);
    assert_eq!(m.normals, vec![Vec3::Z; 3]);
}

#[test]
fn sparse_accessor_substitutes_values() {
    let mut f = Fixture::triangle();
    let idx_view = f.view(&2u16.to_le_bytes(), None);
    let val_view = f.view(&f32_bytes(&[[0.0, 5.0, 0.0]]), None);
    f.doc["accessors"][0]["sparse"] = json!({"count": 1,
        "indices": {"bufferView": idx_view, "componentType": U16},
        "values": {"bufferView": val_view}});
    let s = f.load().unwrap();
    assert_eq!(s.meshes[0].positions[2], Vec3::new(0.0, 5.0, 0.0));
    assert_eq!(s.meshes[0].positions[1], Vec3::X);
}

#[test]
fn sparse_accessor_without_buffer_view_starts_from_zeros() {
    let mut f = Fixture::triangle();
    let idx_view = f.view(&[1u8, 2u8], None);
    let val_view = f.view(&f32_bytes(&[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]), None);
    let acc = f.accessor(json!({"componentType": FLOAT, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0],
        "sparse": {"count": 2, "indices": {"bufferView": idx_view, "componentType": U8}, "values": {"bufferView": val_view}}}));
    f.primitive()["attributes"]["POSITION"] = json!(acc);
    let s = f.load().unwrap();
    assert_eq!(s.meshes[0].positions, vec![Vec3::ZERO, Vec3::X, Vec3::Y]);
}

#[test]
fn u8_u16_u32_indices_all_load() {
    for ty in [U8, U16, U32] {
        let mut f = Fixture::triangle();
        let idx = f.indices(ty, &[2, 0, 1]);
        f.primitive()["indices"] = json!(idx);
        let s = f.load().unwrap();
        assert_eq!(
            s.meshes[0].triangles,
            vec![[2, 0, 1]],
            "component type {ty}"
        );
    }
}

#[test]
fn non_indexed_primitive_loads() {
    let mut f = Fixture::triangle();
    f.primitive().as_object_mut().unwrap().remove("indices");
    assert_eq!(f.load().unwrap().meshes[0].triangles, vec![[0, 1, 2]]);
}

#[test]
fn triangle_strip_and_fan_are_triangulated() {
    let quad = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
    ];
    for (mode, expect) in [
        (5, vec![[0, 1, 2], [1, 3, 2]]),
        (6, vec![[1, 2, 0], [2, 3, 0]]),
    ] {
        let mut f = Fixture::empty();
        let pos = f.vec3(&quad);
        let nrm = f.vec3(&[[0.0, 0.0, 1.0]; 4]);
        let order: &[u32] = if mode == 5 {
            &[0, 1, 2, 3]
        } else {
            &[0, 1, 3, 2]
        };
        let idx = f.indices(U16, order);
        *f.primitive() =
            json!({"attributes": {"POSITION": pos, "NORMAL": nrm}, "indices": idx, "mode": mode});
        let m = &f.load().unwrap().meshes[0];
        let tris: Vec<[u32; 3]> = m
            .triangles
            .iter()
            .map(|t| t.map(|i| order.iter().position(|&o| o == i).unwrap() as u32))
            .collect();
        assert_eq!(tris, expect, "mode {mode}");
        for t in &m.triangles {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            assert!(
                (b - a).cross(c - a).z > 0.0,
                "mode {mode} flipped a triangle"
            );
        }
    }
}

#[test]
fn nested_nodes_compose_trs_and_matrix() {
    let mut f = Fixture::triangle();
    f.doc["nodes"] = json!([
        {"translation": [1, 0, 0], "scale": [2, 2, 2], "children": [1]},
        {"matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,1,0,1], "children": [2]},
        {"rotation": [0, 0.7071068, 0, 0.7071068], "mesh": 0},
    ]);
    let s = f.load().unwrap();
    assert_eq!(s.instances.len(), 1);
    let expect = Mat4::from_translation(Vec3::X)
        * Mat4::from_scale(Vec3::splat(2.0))
        * Mat4::from_translation(Vec3::Y)
        * Mat4::from_rotation_y(std::f32::consts::FRAC_PI_2);
    assert!(s.instances[0].transform.abs_diff_eq(expect, 1e-5));
    assert!(
        (s.instances[0].transform.transform_point3(Vec3::ZERO) - Vec3::new(1.0, 2.0, 0.0)).length()
            < 1e-5
    );
}

#[test]
fn shared_mesh_gives_one_mesh_and_two_instances() {
    let mut f = Fixture::triangle();
    f.doc["nodes"] = json!([{"mesh": 0}, {"mesh": 0, "translation": [0, 0, -2]}]);
    f.doc["scenes"][0]["nodes"] = json!([0, 1]);
    let s = f.load().unwrap();
    assert_eq!((s.meshes.len(), s.instances.len()), (1, 2));
    assert_eq!(s.triangle_count(), 2);
}

#[test]
fn default_scene_property_selects_among_several_scenes() {
    let mut f = Fixture::triangle();
    f.doc["nodes"] = json!([{"mesh": 0}, {"mesh": 0, "translation": [5, 0, 0]}]);
    f.doc["scenes"] = json!([{"nodes": [0]}, {"nodes": [1]}]);
    f.doc["scene"] = json!(1);
    let s = f.load().unwrap();
    assert_eq!(s.instances[0].transform.w_axis.x, 5.0);
    f.doc.as_object_mut().unwrap().remove("scene");
    let s = f.load().unwrap();
    assert_eq!(
        s.instances[0].transform.w_axis.x, 0.0,
        "scene 0 when `scene` is absent"
    );
}

#[test]
fn points_and_lines_are_skipped_and_triangles_kept() {
    let mut f = Fixture::triangle();
    let tri = f.primitive().clone();
    let mut points = tri.clone();
    points["mode"] = json!(0);
    let mut lines = tri.clone();
    lines["mode"] = json!(1);
    f.doc["meshes"][0]["primitives"] = json!([points, tri, lines]);
    let s = f.load().unwrap();
    assert_eq!(s.meshes.len(), 1);
    assert_eq!(s.instances.len(), 1);
}

#[test]
fn missing_normals_are_computed_flat() {
    let mut f = Fixture::empty();
    // Two triangles sharing an edge, folded 90°: flat normals differ per face.
    let pos = f.vec3(&[
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, -1.0],
    ]);
    let idx = f.indices(U16, &[0, 1, 2, 0, 3, 1]);
    *f.primitive() = json!({"attributes": {"POSITION": pos}, "indices": idx});
    let s = f.load().unwrap();
    let m = &s.meshes[0];
    assert_invariants(&s);
    assert_eq!(m.triangles.len(), 2);
    assert_eq!(&m.normals[0..3], &[Vec3::Z; 3]);
    assert_eq!(&m.normals[3..6], &[Vec3::NEG_Y; 3]);
}

#[test]
fn zero_area_triangle_is_dropped() {
    let mut f = Fixture::triangle();
    let idx = f.indices(U16, &[0, 1, 2, 0, 1, 1, 0, 0, 0]);
    f.primitive()["indices"] = json!(idx);
    let s = f.load().unwrap();
    assert_eq!(s.meshes[0].triangles, vec![[0, 1, 2]]);
}

#[test]
fn zero_length_normal_is_repaired() {
    let mut f = Fixture::empty();
    let pos = f.vec3(&TRI);
    let nrm = f.vec3(&[[0.0, 0.0, 0.0], [0.0, 0.0, 2.0], [0.0, 0.0, 1.0]]);
    *f.primitive() = json!({"attributes": {"POSITION": pos, "NORMAL": nrm}});
    let s = f.load().unwrap();
    assert_invariants(&s);
    assert_eq!(s.meshes[0].normals, vec![Vec3::Z; 3]);
}

#[test]
fn lights_convert_to_radiometric_units_and_point_along_node_minus_z() {
    let mut f = Fixture::triangle();
    f.doc["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"type": "point", "color": [1.0, 0.5, 0.25], "intensity": 683.0},
        {"type": "directional", "intensity": 1366.0},
        {"type": "spot", "intensity": 68.3, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.4}},
    ]}});
    for l in 0..3 {
        push(
            &mut f.doc["nodes"],
            json!({"translation": [0, 3, 0], "rotation": [-0.7071068, 0, 0, 0.7071068],
            "extensions": {"KHR_lights_punctual": {"light": l}}}),
        );
    }
    f.doc["scenes"][0]["nodes"] = json!([0, 1, 2, 3]);
    let s = f.load().unwrap();
    assert_eq!(s.lights.len(), 3);
    assert_eq!(s.lights[0].kind, LightKind::Point);
    assert!(
        (s.lights[0].intensity - Vec3::new(1.0, 0.5, 0.25)).length() < 1e-6,
        "cd → W/sr"
    );
    assert_eq!(s.lights[1].kind, LightKind::Directional);
    assert!(
        (s.lights[1].intensity - Vec3::splat(2.0)).length() < 1e-6,
        "lx → W/m²"
    );
    assert!((s.lights[2].intensity - Vec3::splat(0.1)).length() < 1e-6);
    assert_eq!(
        s.lights[2].kind,
        LightKind::Spot {
            inner_cone_angle: 0.2,
            outer_cone_angle: 0.4
        }
    );
    for l in &s.lights {
        assert!(
            (l.direction - Vec3::NEG_Y).length() < 1e-5,
            "{:?}",
            l.direction
        );
        assert!((l.position - Vec3::new(0.0, 3.0, 0.0)).length() < 1e-5);
    }
}

#[test]
fn perspective_camera_is_used_and_orthographic_skipped() {
    let mut f = Fixture::triangle();
    f.doc["cameras"] = json!([
        {"type": "orthographic", "orthographic": {"xmag": 1, "ymag": 1, "znear": 0.1, "zfar": 10}},
        {"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}},
    ]);
    f.doc["nodes"] = json!([{"mesh": 0}, {"camera": 0}, {"camera": 1, "translation": [0, 0, 4], "scale": [3, 3, 3]}]);
    f.doc["scenes"][0]["nodes"] = json!([0, 1, 2]);
    let s = f.load().unwrap();
    assert_eq!(s.cameras.len(), 1);
    assert_eq!(s.camera.yfov, 0.8);
    assert_eq!(s.camera.zfar, None);
    assert!(
        s.camera
            .transform
            .abs_diff_eq(Mat4::from_translation(Vec3::new(0.0, 0.0, 4.0)), 1e-6),
        "scale dropped"
    );
}

#[test]
fn every_perspective_camera_is_kept_in_node_order_and_the_first_is_the_scenes() {
    let mut f = Fixture::triangle();
    f.doc["cameras"] = json!([
        {"type": "perspective", "perspective": {"yfov": 0.5, "znear": 0.1}},
        {"type": "perspective", "perspective": {"yfov": 0.9, "znear": 0.2}},
    ]);
    // Node order, not camera order: node 1 uses camera 1.
    f.doc["nodes"] = json!([
        {"mesh": 0},
        {"camera": 1, "translation": [1, 0, 4]},
        {"camera": 0, "translation": [0, 2, 4]},
    ]);
    f.doc["scenes"][0]["nodes"] = json!([0, 1, 2]);
    let s = f.load().unwrap();
    assert_eq!(s.cameras.len(), 2);
    assert_eq!((s.cameras[0].yfov, s.cameras[1].yfov), (0.9, 0.5));
    assert_eq!(s.cameras[1].position(), Vec3::new(0.0, 2.0, 4.0));
    assert_eq!(s.camera, s.cameras[0]);
}

#[test]
fn scene_without_camera_gets_a_framing_camera() {
    // A three-quarter view from above (+X, +Y, +Z), looking at the bounds' centre.
    let s = Fixture::triangle().load().unwrap();
    assert!(s.cameras.is_empty());
    let eye = s.camera.position();
    assert!(eye.x > 0.3 && eye.y > 0.2 && eye.z > 0.3, "{eye}");
    let forward = -s.camera.transform.z_axis.truncate().normalize();
    let to_centre = (s.bounds().center() - eye).normalize();
    assert!(forward.dot(to_centre) > 0.9999, "{forward} vs {to_centre}");
}

#[test]
fn materials_map_metallic_roughness_to_uber_bsdf() {
    let mut f = Fixture::triangle();
    f.doc["materials"] = json!([
        {"name": "gold", "pbrMetallicRoughness": {"baseColorFactor": [1.0, 0.8, 0.3, 1], "metallicFactor": 1, "roughnessFactor": 0}},
        {"name": "plastic", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0, "roughnessFactor": 0.5}},
        {"name": "glass", "pbrMetallicRoughness": {"metallicFactor": 0, "roughnessFactor": 0},
         "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.33}}},
        {"name": "lamp", "emissiveFactor": [1, 1, 1], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 683}}},
        {"name": "exact", "extras": {"ispm": {"lambertian": [0.1, 0.2, 0.3], "glossy": [0.4, 0.4, 0.4], "exponent": "inf",
            "transmission": [0.5, 0.4, 0.3], "ior": 1.3, "fresnel": true}}},
    ]);
    let s = f.load().unwrap();
    let m = &s.materials;
    assert_eq!(m[0].glossy, Vec3::new(1.0, 0.8, 0.3));
    assert_eq!(m[0].lambertian, Vec3::ZERO);
    assert!(!m[0].fresnel && m[0].exponent.is_infinite());
    assert!(m[1].fresnel);
    assert!(
        (m[1].exponent - (2.0 / 0.0625 - 2.0)).abs() < 1e-3,
        "α = r², σ = 2/α² − 2"
    );
    assert!((m[1].glossy.x - 0.04).abs() < 1e-6, "F0 of η = 1.5");
    assert!(
        (m[1].lambertian.x - 0.48).abs() < 1e-6,
        "(1 − F0)·c: glTF's fresnel_mix"
    );
    assert!(m[2].transmission.x > 0.9 && m[2].ior == 1.33 && m[2].lambertian == Vec3::ZERO);
    assert!(
        (m[3].emission - Vec3::ONE).length() < 1e-6,
        "683 nits = 1 W/(m²·sr)"
    );
    assert_eq!(m[4].lambertian, Vec3::new(0.1, 0.2, 0.3));
    assert_eq!(m[4].glossy, Vec3::splat(0.4));
    assert_eq!(m[4].transmission, Vec3::new(0.5, 0.4, 0.3));
    assert!(m[4].exponent.is_infinite() && m[4].fresnel && m[4].ior == 1.3);
    for mat in m {
        let sum = mat.lambertian + mat.glossy + mat.transmission;
        assert!(sum.max_element() <= 1.0 + 1e-5, "{}: {sum}", mat.name);
    }
}

#[test]
fn bad_ispm_extras_are_an_error() {
    let mut f = Fixture::triangle();
    f.doc["materials"] = json!([{"extras": {"ispm": {"exponent": "huge"}}}]);
    assert_error(f.load(), "fixture.gltf", "exponent");
    f.doc["materials"] = json!([{"extras": {"ispm": {"lambertian": [2, 0, 0]}}}]);
    assert_error(f.load(), "fixture.gltf", "lambertian");
}

#[test]
fn base_color_png_becomes_an_rgba8_texture() {
    let mut png = Vec::new();
    let img = image::RgbaImage::from_fn(2, 3, |x, y| {
        image::Rgba([x as u8 * 100, y as u8 * 50, 7, 255])
    });
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let mut f = Fixture::triangle();
    let view = f.view(&png, None);
    f.doc["images"] = json!([{"bufferView": view, "mimeType": "image/png"}]);
    f.doc["textures"] = json!([{"source": 0}]);
    f.doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    f.primitive()["material"] = json!(0);
    let s = f.load().unwrap();
    assert_eq!(s.materials[0].lambertian_texture, Some(0));
    let t = &s.textures[0];
    assert_eq!((t.width, t.height), (2, 3));
    assert_eq!(&t.rgba8[..8], &[0, 0, 7, 255, 100, 0, 7, 255]);
}

#[test]
fn inconsistent_light_and_camera_objects_are_errors_not_panics() {
    let cases = [
        json!({"extensions": {"KHR_lights_punctual": {"lights": [{"type": "spot", "intensity": 1}]}}}),
        json!({"extensions": {"KHR_lights_punctual": {"lights": [{"type": "sun"}]}}}),
        json!({"extensions": {"KHR_lights_punctual": {"lights": []}}}),
        json!({}),
        json!({"cameras": [{"type": "perspective"}]}),
        json!({"cameras": [{"type": "orthographic"}]}),
        json!({"cameras": [{"type": "fisheye", "perspective": {"yfov": 1, "znear": 0.1}}]}),
    ];
    for (i, extra) in cases.iter().enumerate() {
        let mut f = Fixture::triangle();
        for (k, v) in extra.as_object().unwrap() {
            f.doc[k] = v.clone();
        }
        let node = if extra.get("cameras").is_some() {
            json!({"camera": 0})
        } else {
            json!({"extensions": {"KHR_lights_punctual": {"light": 0}}})
        };
        push(&mut f.doc["nodes"], node);
        f.doc["scenes"][0]["nodes"] = json!([0, 1]);
        let r = std::panic::catch_unwind(|| f.load());
        match r {
            Ok(r) => assert_error(r, "fixture.gltf", "invalid"),
            Err(_) => panic!("case {i} panicked"),
        }
    }
}
