//! A minimal glTF 2.0 binary writer: JSON via serde_json plus one BIN chunk. Writes meshes,
//! materials, a node hierarchy, KHR_lights_punctual lights, cameras and animations.

use super::shapes::{look_rotation, Geometry};
use crate::scene::units::{watts_per_m2_to_lux, watts_per_sr_to_candela};
use glam::{Quat, Vec3};
use serde_json::{json, Map, Value};
use std::collections::BTreeSet;

/// Exact über-BSDF parameters plus the standard PBR values shown by other viewers.
pub struct MaterialSpec {
    pub name: &'static str,
    pub base_color: [f32; 3],
    pub metallic: f32,
    pub roughness: f32,
    /// KHR_materials_transmission factor (0: extension not written).
    pub transmission_factor: f32,
    /// KHR_materials_ior (None: extension not written).
    pub ior_ext: Option<f32>,
    pub lambertian: [f32; 3],
    pub glossy: [f32; 3],
    pub exponent: f32,
    pub transmission: [f32; 3],
    pub ior: f32,
    pub fresnel: bool,
    pub double_sided: bool,
    /// `emissiveFactor` and its KHR_materials_emissive_strength (luminance in nits for factor
    /// 1; `None`: not emissive). The loader turns it into W/(m²·sr) by `scene::units`.
    pub emission: Option<([f32; 3], f32)>,
}

impl MaterialSpec {
    /// A rough diffuse (Lambertian) material.
    pub fn diffuse(name: &'static str, rho: [f32; 3]) -> Self {
        Self {
            name,
            base_color: rho,
            metallic: 0.0,
            roughness: 1.0,
            transmission_factor: 0.0,
            ior_ext: None,
            lambertian: rho,
            glossy: [0.0; 3],
            exponent: 0.0,
            transmission: [0.0; 3],
            ior: 1.5,
            fresnel: false,
            double_sided: false,
            emission: None,
        }
    }

    /// A perfect mirror (σ = ∞) of reflectance `rho`, metallic for other viewers, double-sided.
    pub fn mirror(name: &'static str, rho: [f32; 3]) -> Self {
        Self {
            base_color: rho,
            metallic: 1.0,
            roughness: 0.0,
            lambertian: [0.0; 3],
            glossy: rho,
            exponent: f32::INFINITY,
            double_sided: true,
            ..Self::diffuse(name, [0.0; 3])
        }
    }

    /// Clear glass of refractive index η = 1.5: 95 % transmission, a Fresnel-weighted mirror
    /// (ρS = 0.04 at normal incidence), no diffuse part.
    pub fn glass(name: &'static str) -> Self {
        Self {
            base_color: [1.0, 1.0, 1.0],
            roughness: 0.0,
            transmission_factor: 0.95,
            ior_ext: Some(1.5),
            lambertian: [0.0; 3],
            glossy: [0.04; 3],
            exponent: f32::INFINITY,
            transmission: [0.95; 3],
            ior: 1.5,
            fresnel: true,
            ..Self::diffuse(name, [0.0; 3])
        }
    }
}

/// Accumulates a glTF document and its BIN chunk.
#[derive(Default)]
pub struct GltfWriter {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
    meshes: Vec<Value>,
    materials: Vec<Value>,
    nodes: Vec<Value>,
    lights: Vec<Value>,
    cameras: Vec<Value>,
    animations: Vec<Value>,
    /// Nodes that are some node's child (not roots of the scene).
    children: BTreeSet<usize>,
    extensions: BTreeSet<&'static str>,
}

/// Keyframes of one animated node property (`path`: `"translation"`, `"rotation"` or
/// `"scale"`; `interpolation`: `"STEP"`, `"LINEAR"` or `"CUBICSPLINE"`). `values` holds 3
/// (translation, scale) or 4 (rotation) floats per key, three keys' worth per time for cubic
/// splines (in-tangent, value, out-tangent).
pub struct AnimationChannel<'a> {
    pub node: usize,
    pub path: &'static str,
    pub interpolation: &'static str,
    pub times: &'a [f32],
    pub values: &'a [f32],
}

impl GltfWriter {
    /// A buffer view of `bytes`; `target` 0: none (animation data).
    fn push_view(&mut self, bytes: &[u8], target: u32) -> usize {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        let mut view =
            json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()});
        if target != 0 {
            view["target"] = json!(target);
        }
        self.views.push(view);
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }

    fn push_vec(&mut self, data: &[f32], dims: usize, minmax: bool) -> usize {
        self.push_floats(data, dims, minmax, 34962)
    }

    fn push_floats(&mut self, data: &[f32], dims: usize, minmax: bool, target: u32) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let view = self.push_view(&bytes, target);
        let ty = ["", "SCALAR", "VEC2", "VEC3", "VEC4"][dims];
        let mut acc = json!({"bufferView": view, "componentType": 5126, "count": data.len() / dims, "type": ty});
        if minmax {
            let mut min = vec![f32::INFINITY; dims];
            let mut max = vec![f32::NEG_INFINITY; dims];
            for c in data.chunks_exact(dims) {
                for k in 0..dims {
                    min[k] = min[k].min(c[k]);
                    max[k] = max[k].max(c[k]);
                }
            }
            acc["min"] = json!(min);
            acc["max"] = json!(max);
        }
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    /// Adds a mesh of one primitive; returns its index. A geometry without normals is written
    /// without the NORMAL attribute (the loader then computes flat normals, as glTF requires).
    pub fn mesh(&mut self, name: &str, g: &Geometry, material: usize) -> usize {
        let p: Vec<f32> = g.positions.iter().flat_map(|v| v.to_array()).collect();
        let n: Vec<f32> = g.normals.iter().flat_map(|v| v.to_array()).collect();
        let t: Vec<f32> = g.uvs.iter().flat_map(|v| v.to_array()).collect();
        let pa = self.push_vec(&p, 3, true);
        let na = (!n.is_empty()).then(|| self.push_vec(&n, 3, false));
        let ta = self.push_vec(&t, 2, false);
        let ia = if g.positions.len() <= u16::MAX as usize {
            let bytes: Vec<u8> = g
                .indices
                .iter()
                .flat_map(|&i| (i as u16).to_le_bytes())
                .collect();
            let view = self.push_view(&bytes, 34963);
            self.accessors.push(json!({"bufferView": view, "componentType": 5123, "count": g.indices.len(), "type": "SCALAR"}));
            self.accessors.len() - 1
        } else {
            let bytes: Vec<u8> = g.indices.iter().flat_map(|&i| i.to_le_bytes()).collect();
            let view = self.push_view(&bytes, 34963);
            self.accessors.push(json!({"bufferView": view, "componentType": 5125, "count": g.indices.len(), "type": "SCALAR"}));
            self.accessors.len() - 1
        };
        let mut attributes = json!({"POSITION": pa, "TEXCOORD_0": ta});
        if let Some(na) = na {
            attributes["NORMAL"] = json!(na);
        }
        self.meshes.push(json!({"name": name, "primitives": [{
            "attributes": attributes, "indices": ia, "material": material}]}));
        self.meshes.len() - 1
    }

    /// Adds a material; returns its index.
    pub fn material(&mut self, m: &MaterialSpec) -> usize {
        let [r, g, b] = m.base_color;
        let exponent = if m.exponent.is_infinite() {
            json!("inf")
        } else {
            json!(m.exponent)
        };
        let mut v = json!({
            "name": m.name,
            "pbrMetallicRoughness": {"baseColorFactor": [r, g, b, 1.0], "metallicFactor": m.metallic, "roughnessFactor": m.roughness},
            "extras": {"ispm": {"lambertian": m.lambertian, "glossy": m.glossy, "exponent": exponent,
                "transmission": m.transmission, "ior": m.ior, "fresnel": m.fresnel}},
        });
        let mut ext = Map::new();
        if m.transmission_factor > 0.0 {
            ext.insert(
                "KHR_materials_transmission".into(),
                json!({"transmissionFactor": m.transmission_factor}),
            );
            self.extensions.insert("KHR_materials_transmission");
        }
        if let Some(ior) = m.ior_ext {
            ext.insert("KHR_materials_ior".into(), json!({"ior": ior}));
            self.extensions.insert("KHR_materials_ior");
        }
        if let Some((factor, strength)) = m.emission {
            v["emissiveFactor"] = json!(factor);
            if strength != 1.0 {
                ext.insert(
                    "KHR_materials_emissive_strength".into(),
                    json!({"emissiveStrength": strength}),
                );
                self.extensions.insert("KHR_materials_emissive_strength");
            }
        }
        if !ext.is_empty() {
            v["extensions"] = Value::Object(ext);
        }
        if m.double_sided {
            v["doubleSided"] = json!(true);
        }
        self.materials.push(v);
        self.materials.len() - 1
    }

    /// Adds a node placing `mesh` with translation and rotation; returns the node's index.
    pub fn mesh_node(&mut self, name: &str, mesh: usize, t: Vec3, r: Quat) -> usize {
        self.nodes.push(json!({"name": name, "mesh": mesh, "translation": t.to_array(), "rotation": r.to_array()}));
        self.nodes.len() - 1
    }

    /// Adds an empty node (a group) with translation and rotation; returns its index.
    pub fn group(&mut self, name: &str, t: Vec3, r: Quat) -> usize {
        self.nodes
            .push(json!({"name": name, "translation": t.to_array(), "rotation": r.to_array()}));
        self.nodes.len() - 1
    }

    /// Makes `child` (a node added before) a child of `parent`: it leaves the scene's roots.
    pub fn add_child(&mut self, parent: usize, child: usize) {
        let children = &mut self.nodes[parent]["children"];
        if children.is_null() {
            *children = json!([]);
        }
        if let Some(list) = children.as_array_mut() {
            list.push(json!(child));
        }
        self.children.insert(child);
    }

    /// Adds an animation of `channels`; returns its index.
    pub fn animation(&mut self, name: &str, channels: &[AnimationChannel]) -> usize {
        let mut samplers = Vec::new();
        let mut targets = Vec::new();
        for (i, c) in channels.iter().enumerate() {
            let input = self.push_floats(c.times, 1, true, 0);
            let dims = if c.path == "rotation" { 4 } else { 3 };
            let output = self.push_floats(c.values, dims, false, 0);
            samplers
                .push(json!({"input": input, "output": output, "interpolation": c.interpolation}));
            targets.push(json!({"sampler": i, "target": {"node": c.node, "path": c.path}}));
        }
        self.animations
            .push(json!({"name": name, "channels": targets, "samplers": samplers}));
        self.animations.len() - 1
    }

    /// Adds a spot light (intensity in W/sr, written in candela) at `pos` aiming at `target`.
    pub fn spot(
        &mut self,
        name: &str,
        pos: Vec3,
        target: Vec3,
        color: [f32; 3],
        w_per_sr: f32,
        cone: (f32, f32),
    ) -> usize {
        self.lights
            .push(json!({"name": name, "type": "spot", "color": color,
            "intensity": watts_per_sr_to_candela(w_per_sr),
            "spot": {"innerConeAngle": cone.0, "outerConeAngle": cone.1}}));
        self.light_node(name, pos, target - pos)
    }

    /// Adds a point light (intensity in W/sr, written in candela) at `pos`; returns its node.
    pub fn point(&mut self, name: &str, pos: Vec3, color: [f32; 3], w_per_sr: f32) -> usize {
        self.lights
            .push(json!({"name": name, "type": "point", "color": color,
            "intensity": watts_per_sr_to_candela(w_per_sr)}));
        self.light_node(name, pos, Vec3::NEG_Z)
    }

    /// Adds a directional light travelling along `dir` (irradiance in W/m², written in lux);
    /// returns its node.
    pub fn sun(&mut self, name: &str, dir: Vec3, color: [f32; 3], w_per_m2: f32) -> usize {
        self.lights
            .push(json!({"name": name, "type": "directional", "color": color,
            "intensity": watts_per_m2_to_lux(w_per_m2)}));
        self.light_node(name, Vec3::ZERO, dir)
    }

    fn light_node(&mut self, name: &str, pos: Vec3, dir: Vec3) -> usize {
        let light = self.lights.len() - 1;
        self.extensions.insert("KHR_lights_punctual");
        self.nodes
            .push(json!({"name": name, "translation": pos.to_array(),
            "rotation": look_rotation(dir).to_array(),
            "extensions": {"KHR_lights_punctual": {"light": light}}}));
        self.nodes.len() - 1
    }

    /// Adds a perspective camera at `eye` looking at `target`; returns its node.
    pub fn camera(&mut self, name: &str, eye: Vec3, target: Vec3, yfov: f32) -> usize {
        self.cameras
            .push(json!({"name": name, "type": "perspective",
            "perspective": {"yfov": yfov, "znear": 0.05, "zfar": 50.0, "aspectRatio": 1.0}}));
        self.nodes
            .push(json!({"name": name, "camera": self.cameras.len() - 1,
            "translation": eye.to_array(), "rotation": look_rotation(target - eye).to_array()}));
        self.nodes.len() - 1
    }

    /// The finished `.glb`.
    pub fn glb(mut self) -> Vec<u8> {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        let mut doc = json!({
            "asset": {"version": "2.0", "generator": "ispm make-scenes"},
            "scene": 0,
            "scenes": [{"nodes": (0..self.nodes.len())
                .filter(|n| !self.children.contains(n))
                .collect::<Vec<_>>()}],
            "nodes": self.nodes, "meshes": self.meshes, "materials": self.materials,
            "accessors": self.accessors, "bufferViews": self.views,
            "buffers": [{"byteLength": self.bin.len()}],
        });
        if !self.cameras.is_empty() {
            doc["cameras"] = json!(self.cameras);
        }
        if !self.animations.is_empty() {
            doc["animations"] = json!(self.animations);
        }
        if !self.lights.is_empty() {
            doc["extensions"] = json!({"KHR_lights_punctual": {"lights": self.lights}});
        }
        if !self.extensions.is_empty() {
            doc["extensionsUsed"] = json!(self.extensions);
        }
        let mut text = doc.to_string().into_bytes();
        while text.len() % 4 != 0 {
            text.push(b' ');
        }
        let total = 12 + 8 + text.len() + 8 + self.bin.len();
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(text.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&text);
        out.extend_from_slice(&(self.bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&self.bin);
        out
    }
}
