//! The project's own scenes, written as glTF 2.0 binary (`.glb`) with serde_json.
//!
//! `cargo run --example make-scenes` writes [`all`] to `assets/`; `tests/scene_bundled.rs`
//! checks that the committed files equal what this module produces now. Each material carries
//! standard metallic-roughness values (so other viewers show something sensible) and its exact
//! über-BSDF parameters in `extras.ispm`, which the loader applies verbatim.

use super::units::{watts_per_m2_to_lux, watts_per_sr_to_candela};
use glam::{Mat3, Quat, Vec2, Vec3};
use serde_json::{json, Map, Value};
use std::collections::{BTreeSet, HashMap};

/// Every bundled scene: `(name, .glb bytes)`.
pub fn all() -> Vec<(&'static str, Vec<u8>)> {
    vec![
        ("cornell-box", cornell_box()),
        ("caustic-ring", caustic_ring()),
        ("glass-sphere", glass_sphere()),
    ]
}

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
        }
    }
}

/// Indexed triangles with per-vertex normals and UVs (CCW seen from the normal's side).
#[derive(Default, Clone)]
pub struct Geometry {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    pub indices: Vec<u32>,
}

impl Geometry {
    fn append(&mut self, other: Geometry) {
        let base = self.positions.len() as u32;
        self.positions.extend(other.positions);
        self.normals.extend(other.normals);
        self.uvs.extend(other.uvs);
        self.indices.extend(other.indices.iter().map(|i| i + base));
    }
}

/// A rectangle centred at `center` facing `normal`, with half-sizes `hu`, `hv` along tangents.
pub fn quad(center: Vec3, normal: Vec3, hu: f32, hv: f32) -> Geometry {
    let n = normal.normalize();
    let a = if n.y.abs() > 0.5 { Vec3::X } else { Vec3::Y };
    let u = a.cross(n).normalize();
    let v = n.cross(u);
    let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    Geometry {
        positions: corners
            .iter()
            .map(|&(s, t)| center + u * (s * hu) + v * (t * hv))
            .collect(),
        normals: vec![n; 4],
        uvs: corners
            .iter()
            .map(|&(s, t)| Vec2::new(s * 0.5 + 0.5, 0.5 - t * 0.5))
            .collect(),
        indices: vec![0, 1, 2, 0, 2, 3],
    }
}

/// An axis-aligned box centred at the origin with outward normals.
pub fn cuboid(half: Vec3) -> Geometry {
    let mut g = Geometry::default();
    for n in [
        Vec3::X,
        Vec3::NEG_X,
        Vec3::Y,
        Vec3::NEG_Y,
        Vec3::Z,
        Vec3::NEG_Z,
    ] {
        let a = if n.y.abs() > 0.5 { Vec3::X } else { Vec3::Y };
        let u = a.cross(n);
        let v = n.cross(u);
        g.append(quad(n * half, n, (u * half).length(), (v * half).length()));
    }
    g
}

/// An icosphere of `radius` centred at the origin, subdivided `levels` times.
pub fn icosphere(radius: f32, levels: u32) -> Geometry {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut pos: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut next = Vec::with_capacity(tris.len() * 4);
        let mut midpoint = |a: u32, b: u32, pos: &mut Vec<Vec3>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                pos.push((pos[a as usize] + pos[b as usize]).normalize());
                pos.len() as u32 - 1
            })
        };
        for [a, b, c] in tris {
            let ab = midpoint(a, b, &mut pos);
            let bc = midpoint(b, c, &mut pos);
            let ca = midpoint(c, a, &mut pos);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }
    let mut indices = Vec::with_capacity(tris.len() * 3);
    for [a, b, c] in tris {
        let (pa, pb, pc) = (pos[a as usize], pos[b as usize], pos[c as usize]);
        let outward = (pb - pa).cross(pc - pa).dot(pa + pb + pc) > 0.0;
        indices.extend(if outward { [a, b, c] } else { [a, c, b] });
    }
    Geometry {
        uvs: pos
            .iter()
            .map(|p| {
                Vec2::new(
                    0.5 + p.z.atan2(p.x) / std::f32::consts::TAU,
                    0.5 - p.y.asin() / std::f32::consts::PI,
                )
            })
            .collect(),
        normals: pos.clone(),
        positions: pos.iter().map(|p| *p * radius).collect(),
        indices,
    }
}

/// A thin-walled open ring standing on y = 0: outer wall, inner wall, top and bottom rims.
pub fn ring(radius: f32, height: f32, thickness: f32, segments: u32) -> Geometry {
    let mut g = Geometry::default();
    let (r_out, r_in) = (radius + thickness * 0.5, radius - thickness * 0.5);
    let dir = |i: u32| {
        let a = i as f32 / segments as f32 * std::f32::consts::TAU;
        Vec3::new(a.cos(), 0.0, -a.sin())
    };
    // Walls: (radius, normal sign). Rims: (y, normal).
    for (r, sign) in [(r_out, 1.0f32), (r_in, -1.0)] {
        let mut w = Geometry::default();
        for i in 0..=segments {
            let d = dir(i);
            for y in [0.0, height] {
                w.positions.push(d * r + Vec3::Y * y);
                w.normals.push(d * sign);
                w.uvs
                    .push(Vec2::new(i as f32 / segments as f32, 1.0 - y / height));
            }
        }
        for i in 0..segments {
            let (b0, t0, b1, t1) = (2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3);
            if sign > 0.0 {
                w.indices.extend([b0, b1, t1, b0, t1, t0]);
            } else {
                w.indices.extend([b0, t1, b1, b0, t0, t1]);
            }
        }
        g.append(w);
    }
    for (y, n) in [(height, Vec3::Y), (0.0, Vec3::NEG_Y)] {
        let mut rim = Geometry::default();
        for i in 0..=segments {
            let d = dir(i);
            for r in [r_in, r_out] {
                rim.positions.push(d * r + Vec3::Y * y);
                rim.normals.push(n);
                rim.uvs
                    .push(Vec2::new(i as f32 / segments as f32, r / r_out));
            }
        }
        for i in 0..segments {
            let (i0, o0, i1, o1) = (2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3);
            if n.y > 0.0 {
                rim.indices.extend([i0, o0, o1, i0, o1, i1]);
            } else {
                rim.indices.extend([i0, o1, o0, i0, i1, o1]);
            }
        }
        g.append(rim);
    }
    g
}

/// Rotation that turns a node's −Z (where lights shine and cameras look) towards `dir`, with
/// +Y kept as close to world up as possible.
pub fn look_rotation(dir: Vec3) -> Quat {
    let f = dir.normalize();
    let up = if f.y.abs() > 0.999 { Vec3::Z } else { Vec3::Y };
    let x = f.cross(up).normalize();
    let y = x.cross(f);
    Quat::from_mat3(&Mat3::from_cols(x, y, -f)).normalize()
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
    extensions: BTreeSet<&'static str>,
}

impl GltfWriter {
    fn push_view(&mut self, bytes: &[u8], target: u32) -> usize {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        self.views.push(json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len(), "target": target}));
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }

    fn push_vec(&mut self, data: &[f32], dims: usize, minmax: bool) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let view = self.push_view(&bytes, 34962);
        let ty = ["", "SCALAR", "VEC2", "VEC3"][dims];
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

    /// Adds a mesh of one primitive; returns its index.
    pub fn mesh(&mut self, name: &str, g: &Geometry, material: usize) -> usize {
        let p: Vec<f32> = g.positions.iter().flat_map(|v| v.to_array()).collect();
        let n: Vec<f32> = g.normals.iter().flat_map(|v| v.to_array()).collect();
        let t: Vec<f32> = g.uvs.iter().flat_map(|v| v.to_array()).collect();
        let (pa, na, ta) = (
            self.push_vec(&p, 3, true),
            self.push_vec(&n, 3, false),
            self.push_vec(&t, 2, false),
        );
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
        self.meshes.push(json!({"name": name, "primitives": [{
            "attributes": {"POSITION": pa, "NORMAL": na, "TEXCOORD_0": ta},
            "indices": ia, "material": material}]}));
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
        if !ext.is_empty() {
            v["extensions"] = Value::Object(ext);
        }
        if m.double_sided {
            v["doubleSided"] = json!(true);
        }
        self.materials.push(v);
        self.materials.len() - 1
    }

    /// Adds a node placing `mesh` with translation and rotation.
    pub fn mesh_node(&mut self, name: &str, mesh: usize, t: Vec3, r: Quat) {
        self.nodes.push(json!({"name": name, "mesh": mesh, "translation": t.to_array(), "rotation": r.to_array()}));
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
    ) {
        self.lights
            .push(json!({"name": name, "type": "spot", "color": color,
            "intensity": watts_per_sr_to_candela(w_per_sr),
            "spot": {"innerConeAngle": cone.0, "outerConeAngle": cone.1}}));
        self.light_node(name, pos, target - pos);
    }

    /// Adds a directional light travelling along `dir` (irradiance in W/m², written in lux).
    pub fn sun(&mut self, name: &str, dir: Vec3, color: [f32; 3], w_per_m2: f32) {
        self.lights
            .push(json!({"name": name, "type": "directional", "color": color,
            "intensity": watts_per_m2_to_lux(w_per_m2)}));
        self.light_node(name, Vec3::ZERO, dir);
    }

    fn light_node(&mut self, name: &str, pos: Vec3, dir: Vec3) {
        let light = self.lights.len() - 1;
        self.extensions.insert("KHR_lights_punctual");
        self.nodes
            .push(json!({"name": name, "translation": pos.to_array(),
            "rotation": look_rotation(dir).to_array(),
            "extensions": {"KHR_lights_punctual": {"light": light}}}));
    }

    /// Adds a perspective camera at `eye` looking at `target`.
    pub fn camera(&mut self, name: &str, eye: Vec3, target: Vec3, yfov: f32) {
        self.cameras
            .push(json!({"name": name, "type": "perspective",
            "perspective": {"yfov": yfov, "znear": 0.05, "zfar": 50.0, "aspectRatio": 1.0}}));
        self.nodes
            .push(json!({"name": name, "camera": self.cameras.len() - 1,
            "translation": eye.to_array(), "rotation": look_rotation(target - eye).to_array()}));
    }

    /// The finished `.glb`.
    pub fn glb(mut self) -> Vec<u8> {
        while self.bin.len() % 4 != 0 {
            self.bin.push(0);
        }
        let mut doc = json!({
            "asset": {"version": "2.0", "generator": "ispm make-scenes"},
            "scene": 0,
            "scenes": [{"nodes": (0..self.nodes.len()).collect::<Vec<_>>()}],
            "nodes": self.nodes, "meshes": self.meshes, "materials": self.materials,
            "accessors": self.accessors, "bufferViews": self.views,
            "buffers": [{"byteLength": self.bin.len()}],
        });
        if !self.cameras.is_empty() {
            doc["cameras"] = json!(self.cameras);
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

const WHITE: [f32; 3] = [0.75, 0.75, 0.75];

/// The paper's Figure 6: a 2 m Cornell box (open towards the camera at +Z) with a glossy purple
/// sphere, a glass sphere (η = 1.3), a white box and two spot lights (white, blue) aiming down.
pub fn cornell_box() -> Vec<u8> {
    let mut w = GltfWriter::default();
    let white = w.material(&MaterialSpec::diffuse("white", WHITE));
    let red = w.material(&MaterialSpec::diffuse("red", [0.63, 0.065, 0.05]));
    let green = w.material(&MaterialSpec::diffuse("green", [0.14, 0.45, 0.091]));
    let purple = w.material(&MaterialSpec {
        base_color: [0.45, 0.15, 0.55],
        roughness: 0.376,
        lambertian: [0.25, 0.05, 0.3],
        glossy: [0.35, 0.2, 0.4],
        exponent: 100.0,
        ..MaterialSpec::diffuse("glossy-purple", [0.0; 3])
    });
    let glass = w.material(&MaterialSpec {
        base_color: [1.0, 1.0, 1.0],
        roughness: 0.0,
        transmission_factor: 0.9,
        ior_ext: Some(1.3),
        lambertian: [0.02; 3],
        glossy: [0.05; 3],
        exponent: f32::INFINITY,
        transmission: [0.9; 3],
        ior: 1.3,
        fresnel: true,
        ..MaterialSpec::diffuse("glass-1.3", [0.0; 3])
    });
    let walls = [
        ("floor", Vec3::ZERO, Vec3::Y, white),
        ("ceiling", Vec3::new(0.0, 2.0, 0.0), Vec3::NEG_Y, white),
        ("back", Vec3::new(0.0, 1.0, -1.0), Vec3::Z, white),
        ("left", Vec3::new(-1.0, 1.0, 0.0), Vec3::X, red),
        ("right", Vec3::new(1.0, 1.0, 0.0), Vec3::NEG_X, green),
    ];
    for (name, c, n, m) in walls {
        let mesh = w.mesh(name, &quad(c, n, 1.0, 1.0), m);
        w.mesh_node(name, mesh, Vec3::ZERO, Quat::IDENTITY);
    }
    let sphere = w.mesh("glossy-sphere", &icosphere(0.3, 3), purple);
    w.mesh_node(
        "glossy-sphere",
        sphere,
        Vec3::new(-0.45, 0.3, -0.35),
        Quat::IDENTITY,
    );
    let ball = w.mesh("glass-sphere", &icosphere(0.32, 4), glass);
    w.mesh_node(
        "glass-sphere",
        ball,
        Vec3::new(0.2, 0.32, 0.35),
        Quat::IDENTITY,
    );
    let block = w.mesh("white-box", &cuboid(Vec3::new(0.25, 0.5, 0.25)), white);
    w.mesh_node(
        "white-box",
        block,
        Vec3::new(0.5, 0.5, -0.45),
        Quat::from_rotation_y(0.3),
    );
    // 4 W/sr from 1.95 m: about 1.05 W/m² on the floor below each light.
    let down = Vec3::new(0.0, -1.95, 0.0);
    let (white_at, blue_at) = (Vec3::new(-0.4, 1.95, 0.0), Vec3::new(0.4, 1.95, 0.0));
    w.spot(
        "white-spot",
        white_at,
        white_at + down,
        [1.0, 1.0, 1.0],
        4.0,
        (0.45, 0.6),
    );
    w.spot(
        "blue-spot",
        blue_at,
        blue_at + down,
        [0.25, 0.45, 1.0],
        4.0,
        (0.45, 0.6),
    );
    w.camera(
        "camera",
        Vec3::new(0.0, 1.0, 3.6),
        Vec3::new(0.0, 1.0, 0.0),
        0.7,
    );
    w.glb()
}

/// The paper's Figure 5: a mirror ring on a diffuse floor lit at 20° elevation, so its
/// reflection focuses into a cardioid caustic inside the ring.
pub fn caustic_ring() -> Vec<u8> {
    let mut w = GltfWriter::default();
    let floor_m = w.material(&MaterialSpec::diffuse("floor", WHITE));
    let metal = w.material(&MaterialSpec {
        base_color: [0.95, 0.93, 0.88],
        metallic: 1.0,
        roughness: 0.0,
        lambertian: [0.0; 3],
        glossy: [0.95, 0.93, 0.88],
        exponent: f32::INFINITY,
        double_sided: true,
        ..MaterialSpec::diffuse("mirror-metal", [0.0; 3])
    });
    let floor = w.mesh("floor", &quad(Vec3::ZERO, Vec3::Y, 2.0, 2.0), floor_m);
    w.mesh_node("floor", floor, Vec3::ZERO, Quat::IDENTITY);
    let r = w.mesh("ring", &ring(0.5, 0.2, 0.015, 192), metal);
    w.mesh_node("ring", r, Vec3::ZERO, Quat::IDENTITY);
    let elevation = 20f32.to_radians();
    let dir = Vec3::new(-elevation.cos(), -elevation.sin(), 0.0);
    w.sun("sun", dir, [1.0, 1.0, 1.0], 3.0);
    w.camera("camera", Vec3::new(0.0, 1.5, 1.2), Vec3::ZERO, 0.7);
    w.glb()
}

/// A glass sphere (η = 1.5) on a diffuse plane under a spot light: a refractive caustic.
pub fn glass_sphere() -> Vec<u8> {
    let mut w = GltfWriter::default();
    let floor_m = w.material(&MaterialSpec::diffuse("floor", WHITE));
    let glass = w.material(&MaterialSpec {
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
        ..MaterialSpec::diffuse("glass-1.5", [0.0; 3])
    });
    let floor = w.mesh("floor", &quad(Vec3::ZERO, Vec3::Y, 3.0, 3.0), floor_m);
    w.mesh_node("floor", floor, Vec3::ZERO, Quat::IDENTITY);
    let ball = w.mesh("glass-sphere", &icosphere(0.5, 4), glass);
    w.mesh_node(
        "glass-sphere",
        ball,
        Vec3::new(0.0, 0.5, 0.0),
        Quat::IDENTITY,
    );
    // 10 W/sr from 3 m: about 1.1 W/m² on the plane.
    w.spot(
        "spot",
        Vec3::new(0.3, 3.0, 0.0),
        Vec3::new(0.0, 0.5, 0.0),
        [1.0, 1.0, 1.0],
        10.0,
        (0.35, 0.45),
    );
    w.camera(
        "camera",
        Vec3::new(2.0, 1.5, 2.0),
        Vec3::new(0.0, 0.4, 0.0),
        0.7,
    );
    w.glb()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_winding(g: &Geometry) {
        for t in g.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| g.positions[i as usize]);
            let face = (b - a).cross(c - a);
            assert!(face.length() > 0.0);
            for &i in t {
                assert!(
                    face.dot(g.normals[i as usize]) > 0.0,
                    "winding disagrees with normal"
                );
            }
        }
    }

    #[test]
    fn generated_shapes_wind_ccw_around_their_normals() {
        check_winding(&quad(Vec3::ZERO, Vec3::NEG_X, 1.0, 2.0));
        check_winding(&cuboid(Vec3::new(1.0, 2.0, 3.0)));
        check_winding(&icosphere(1.0, 2));
        check_winding(&ring(0.5, 0.2, 0.02, 32));
    }

    #[test]
    fn look_rotation_points_minus_z_along_the_direction() {
        for d in [Vec3::NEG_Y, Vec3::new(1.0, -0.3, 0.2), Vec3::Z] {
            let r = look_rotation(d);
            assert!((r * Vec3::NEG_Z - d.normalize()).length() < 1e-5);
        }
    }
}
