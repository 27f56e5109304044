//! glTF test files written the way exporters write them: plain glTF materials (no `extras.ispm`),
//! one buffer embedded in the `.gltf` as a base64 data URI.

use glam::{Quat, Vec3};
use ispm::scene::authoring::{cuboid, quad, GltfWriter, MaterialSpec};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

/// A glTF document as JSON and its one binary buffer.
pub struct GltfDoc {
    pub doc: Value,
    pub bin: Vec<u8>,
}

fn le_u32(b: &[u8], at: usize) -> usize {
    u32::from_le_bytes(b[at..at + 4].try_into().expect("4 bytes")) as usize
}

impl GltfDoc {
    /// Splits a `.glb` into its JSON and BIN chunks.
    pub fn from_glb(glb: &[u8]) -> Self {
        let json_len = le_u32(glb, 12);
        let doc = serde_json::from_slice(&glb[20..20 + json_len]).expect("GLB JSON");
        let bin_at = 20 + json_len;
        let bin_len = le_u32(glb, bin_at);
        Self {
            doc,
            bin: glb[bin_at + 8..bin_at + 8 + bin_len].to_vec(),
        }
    }

    /// The `.gltf` text with the buffer as a base64 data URI.
    pub fn gltf(&self) -> Vec<u8> {
        let mut doc = self.doc.clone();
        doc["buffers"] = json!([{
            "byteLength": self.bin.len(),
            "uri": format!("data:application/octet-stream;base64,{}", base64(&self.bin)),
        }]);
        doc.to_string().into_bytes()
    }

    /// Writes `name.gltf` into `dir`; returns its path.
    pub fn write(&self, dir: &Path, name: &str) -> PathBuf {
        let path = dir.join(format!("{name}.gltf"));
        std::fs::write(&path, self.gltf()).expect("write .gltf");
        path
    }

    /// Adds `name` to `extensionsUsed` (and to `extensionsRequired` when `required`).
    pub fn uses(&mut self, name: &str, required: bool) {
        let lists: &[&str] = if required {
            &["extensionsUsed", "extensionsRequired"]
        } else {
            &["extensionsUsed"]
        };
        for list in lists {
            if self.doc[list].is_null() {
                self.doc[list] = json!([]);
            }
            self.doc[list]
                .as_array_mut()
                .expect("a list")
                .push(json!(name));
        }
    }

    /// Adds a buffer view of `bytes` (an image); returns its index.
    pub fn view(&mut self, bytes: &[u8]) -> usize {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        let views = self.doc["bufferViews"].as_array_mut().expect("views");
        views.push(json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()}));
        self.bin.extend_from_slice(bytes);
        views.len() - 1
    }
}

/// Standard base64 with padding.
pub fn base64(bytes: &[u8]) -> String {
    const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            s.push(if k <= c.len() {
                A[(n >> (18 - 6 * k) & 63) as usize] as char
            } else {
                '='
            });
        }
    }
    s
}

/// A material as Blender's glTF exporter writes a Principled BSDF: double-sided, base colour,
/// metallic 0, roughness 0.5.
pub fn blender_material(name: &str, base_color: [f32; 3]) -> Value {
    let [r, g, b] = base_color;
    json!({"name": name, "doubleSided": true,
           "pbrMetallicRoughness": {"baseColorFactor": [r, g, b, 1.0], "metallicFactor": 0.0,
                                    "roughnessFactor": 0.5}})
}

/// Material 0 of [`object_on_floor`] (the floor).
pub const FLOOR: usize = 0;
/// Material 1 of [`object_on_floor`] (the box).
pub const OBJECT: usize = 1;

/// An object-viewer scene as an exporter writes it: a 4 m floor and a 0.8 m box on it
/// (materials [`FLOOR`] and [`OBJECT`], Blender-style), a camera in front of and above the box,
/// no lights. Put `KHR_lights_punctual` lights in with [`add_light`].
pub fn object_on_floor() -> GltfDoc {
    let mut w = GltfWriter::default();
    let floor_material = w.material(&MaterialSpec::diffuse("floor", [0.8; 3]));
    let box_material = w.material(&MaterialSpec::diffuse("box", [0.8; 3]));
    let floor = w.mesh(
        "floor",
        &quad(Vec3::ZERO, Vec3::Y, 2.0, 2.0),
        floor_material,
    );
    w.mesh_node("floor", floor, Vec3::ZERO, Quat::IDENTITY);
    let block = w.mesh("box", &cuboid(Vec3::splat(0.4)), box_material);
    w.mesh_node("box", block, Vec3::new(0.0, 0.4, 0.0), Quat::IDENTITY);
    w.camera(
        "Camera",
        Vec3::new(0.0, 1.6, 3.2),
        Vec3::new(0.0, 0.4, 0.0),
        0.7,
    );
    let mut gltf = GltfDoc::from_glb(&w.glb());
    gltf.doc["asset"]["generator"] = json!("Khronos glTF Blender I/O v4.2.70");
    gltf.doc["materials"] = json!([
        blender_material("floor", [0.8; 3]),
        blender_material("box", [0.8; 3])
    ]);
    gltf
}

/// Adds a KHR_lights_punctual `light` (JSON as an exporter writes it) on a new root node at
/// `translation` with `rotation`.
pub fn add_light(gltf: &mut GltfDoc, light: Value, translation: Vec3, rotation: Quat) {
    let doc = &mut gltf.doc;
    if doc["extensions"]["KHR_lights_punctual"].is_null() {
        doc["extensions"] = json!({"KHR_lights_punctual": {"lights": []}});
        gltf.uses("KHR_lights_punctual", false);
    }
    let doc = &mut gltf.doc;
    let lights = doc["extensions"]["KHR_lights_punctual"]["lights"]
        .as_array_mut()
        .expect("lights");
    lights.push(light);
    let index = lights.len() - 1;
    let nodes = doc["nodes"].as_array_mut().expect("nodes");
    nodes.push(
        json!({"name": format!("light{index}"), "translation": translation.to_array(),
        "rotation": rotation.to_array(),
        "extensions": {"KHR_lights_punctual": {"light": index}}}),
    );
    let node = nodes.len() - 1;
    doc["scenes"][0]["nodes"]
        .as_array_mut()
        .expect("scene nodes")
        .push(json!(node));
}
