//! The renderer's scene: triangle meshes, instances, über-BSDF materials, lights and a camera.
//!
//! This module never touches Vulkan. The GPU passes, the CPU photon tracer and the reference
//! renderers all read the same [`Scene`], so the physics can be tested without a GPU.
//!
//! Units and frames follow glTF: right-handed, +Y up, metres. Every radiometric quantity in a
//! `Scene` is already converted from glTF's photometric units (see [`units`]), so nothing
//! downstream needs to know about lumens or candela.

mod animation;
pub mod authoring;
pub mod bundled;
pub mod default_light;
pub mod emitters;
mod gltf_data;
mod gltf_light;
mod gltf_material;
mod gltf_mesh;
pub mod load;
pub mod units;

pub use animation::{
    rigid, Animations, Channel, Clip, Interpolation, LightOrbit, LocalTransform, Pose, Property,
    RigNode, Sampler, FRAME_STEP_SECONDS, MIN_ANIMATED_SCALE,
};

use glam::{Mat4, Vec2, Vec3};

/// Index of a [`Mesh`] in [`Scene::meshes`].
pub type MeshId = usize;
/// Index of a [`Material`] in [`Scene::materials`].
pub type MaterialId = usize;
/// Index of a [`Texture`] in [`Scene::textures`].
pub type TextureId = usize;

/// A whole scene, ready to render.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// Triangle meshes in object space, one per glTF primitive.
    pub meshes: Vec<Mesh>,
    /// Placements of meshes in the world (glTF node hierarchy flattened).
    pub instances: Vec<Instance>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub lights: Vec<Light>,
    /// The camera the renderer uses: the file's first camera, or [`Camera::framing`] of the
    /// scene when the file has none.
    pub camera: Camera,
    /// Every camera in the file, in node order (may be empty).
    pub cameras: Vec<Camera>,
    /// What moves and how: glTF animation clips with the node hierarchy they drive, and the
    /// built-in light orbit ([`Scene::pose_at`]; empty for a static scene).
    pub animations: Animations,
    /// `lights[0]` is the loader's default key light, not the file's: the file has no light
    /// and no emissive surface ([`default_light`]).
    pub default_light: bool,
}

/// An indexed triangle mesh in object space with one material (one glTF primitive).
///
/// Invariants (established by the loader, relied on everywhere else): `normals` and `uvs` have
/// one entry per position; every index is `< positions.len()`; every value is finite; every
/// normal has unit length.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    pub name: String,
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    pub triangles: Vec<[u32; 3]>,
    pub material: MaterialId,
}

/// One placement of a mesh in the world.
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    pub name: String,
    pub mesh: MeshId,
    /// World-from-object transform (finite, invertible).
    pub transform: Mat4,
}

/// Largest emitted radiance a [`Material`] has, W/(m²·sr) (6.8 million nits, brighter than any
/// lamp's surface): the loader scales brighter emission down to it with a warning, so radiance
/// stays finite in every half-float buffer (the largest half float is 65504) and in photon
/// powers.
pub const MAX_EMISSION: f32 = 1e4;

/// Parameters of the über-BSDF (DESIGN.md §2; `photon::bsdf` owns the formulas).
///
/// The lobes are, in the order importance sampling picks them: Lambertian (`lambertian`),
/// glossy or perfect mirror (`glossy`, `exponent`), refraction (`transmission`, `ior`).
/// Reflectances are linear RGB in [0, 1]; their sum per channel is kept ≤ 1 by the loader.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// ρL: Lambertian reflectance.
    pub lambertian: Vec3,
    /// Multiplies `lambertian` (sRGB texture, decoded to linear when sampled).
    pub lambertian_texture: Option<TextureId>,
    /// ρS: glossy/mirror reflectance at normal incidence.
    pub glossy: Vec3,
    /// Glossy exponent σ ≥ 0 of the normalised lobe; `f32::INFINITY` means a perfect mirror.
    pub exponent: f32,
    /// ρt: fraction refracted through the surface.
    pub transmission: Vec3,
    /// η of the material's interior (the outside is vacuum, η = 1).
    pub ior: f32,
    /// When true the glossy and transmitted weights follow the exact dielectric Fresnel term for
    /// `ior` (glass, water, plastics); when false `glossy` is used as it is (metals, paint).
    pub fresnel: bool,
    /// Emitted radiance, W/(m²·sr), linear RGB, each channel in [0, [`MAX_EMISSION`]].
    pub emission: Vec3,
    /// Rendered from both sides (glTF `doubleSided`).
    pub double_sided: bool,
    /// KHR_materials_unlit: `emission` is the colour the surface is shown at (its base colour)
    /// and every reflectance is 0. The eye sees it; it is no light source: emitters, photon
    /// emission and the default-light rule skip it ([`Material::is_emitter`]).
    pub unlit: bool,
}

impl Default for Material {
    fn default() -> Self {
        // glTF's default material: white, rough, dielectric.
        Self {
            name: String::from("default"),
            lambertian: Vec3::splat(0.8),
            lambertian_texture: None,
            glossy: Vec3::ZERO,
            exponent: 0.0,
            transmission: Vec3::ZERO,
            ior: 1.5,
            fresnel: false,
            emission: Vec3::ZERO,
            double_sided: false,
            unlit: false,
        }
    }
}

impl Material {
    /// True when the material has a delta (perfect mirror or refraction) lobe.
    pub fn has_delta_lobe(&self) -> bool {
        (self.glossy.max_element() > 0.0 && self.exponent.is_infinite())
            || self.transmission.max_element() > 0.0
    }

    /// True when the surface emits light into the scene: non-zero emission on a lit material
    /// (an unlit material's emission is only its displayed colour).
    pub fn is_emitter(&self) -> bool {
        !self.unlit && self.emission.max_element() > 0.0
    }
}

/// An RGBA8 image in sRGB encoding, row-major, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub name: String,
    pub width: u32,
    pub height: u32,
    pub rgba8: Vec<u8>,
}

/// A punctual light (KHR_lights_punctual), in radiometric units.
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    pub name: String,
    pub kind: LightKind,
    /// World-space position (ignored for directional lights).
    pub position: Vec3,
    /// World-space unit vector along which the light travels (spot and directional).
    pub direction: Vec3,
    /// Linear RGB radiant intensity in W/sr for point and spot lights (along `direction` for
    /// area samples); irradiance in W/m² on a surface facing the light for directional lights.
    pub intensity: Vec3,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightKind {
    Point,
    /// Cone angles in radians from the axis, `0 ≤ inner < outer ≤ π/2` (KHR_lights_punctual).
    Spot {
        inner_cone_angle: f32,
        outer_cone_angle: f32,
    },
    Directional,
    /// A point sampled on an emissive surface (`emitters`, issue #18; never in a glTF file): a
    /// one-sided Lambertian emitter whose radiant intensity is `intensity·max(0, cos θ)`, θ from
    /// `direction` (the surface's normal), so its flux is `π·intensity`.
    AreaSample,
}

/// A perspective camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// World-from-camera transform; the camera looks down its local −Z with +Y up.
    pub transform: Mat4,
    /// Vertical field of view in radians.
    pub yfov: f32,
    /// Near clip distance in metres (> 0).
    pub znear: f32,
    /// Far clip distance in metres; `None` for an infinite far plane.
    pub zfar: Option<f32>,
}

impl Default for Camera {
    fn default() -> Self {
        Self {
            transform: Mat4::IDENTITY,
            yfov: 45f32.to_radians(),
            znear: 0.05,
            zfar: None,
        }
    }
}

/// An axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    pub const EMPTY: Self = Self {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }
}

impl Scene {
    /// Number of triangles over all instances (what the paper's Table 2 counts).
    pub fn triangle_count(&self) -> usize {
        self.instances
            .iter()
            .map(|i| self.meshes[i.mesh].triangles.len())
            .sum()
    }

    /// World-space bounds of all instanced geometry.
    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        for inst in &self.instances {
            for &p in &self.meshes[inst.mesh].positions {
                b.grow(inst.transform.transform_point3(p));
            }
        }
        b
    }

    /// For each instance, in instance order, whether its material has a delta lobe (a perfect
    /// mirror or glass: [`Material::has_delta_lobe`]): the instances the environment cubes
    /// leave out (`passes/environment.rs`, `render/photon_frame/environment.rs`).
    pub fn delta_instance_mask(&self) -> Vec<bool> {
        (self.instances.iter())
            .map(|inst| {
                (self.materials.get(self.meshes[inst.mesh].material))
                    .is_some_and(Material::has_delta_lobe)
            })
            .collect()
    }

    /// Each instance of a delta material ([`Self::delta_instance_mask`]) with geometry, in
    /// instance order: its index and world-space bounds. The glass and mirrors' environment
    /// probes (`plan/probes.rs`) are made of these.
    pub fn delta_instance_bounds(&self) -> Vec<(usize, Aabb)> {
        let mut delta = Vec::new();
        let mask = self.delta_instance_mask();
        for (i, inst) in self.instances.iter().enumerate() {
            let mesh = &self.meshes[inst.mesh];
            if !mask[i] {
                continue;
            }
            let mut b = Aabb::EMPTY;
            for &p in &mesh.positions {
                b.grow(inst.transform.transform_point3(p));
            }
            if !b.is_empty() {
                delta.push((i, b));
            }
        }
        delta
    }

    /// World-space triangles of every instance, with the material of each, in instance order.
    pub fn world_triangles(&self) -> Vec<([Vec3; 3], MaterialId)> {
        let mut out = Vec::with_capacity(self.triangle_count());
        for inst in &self.instances {
            let mesh = &self.meshes[inst.mesh];
            for t in &mesh.triangles {
                let p = t.map(|i| inst.transform.transform_point3(mesh.positions[i as usize]));
                out.push((p, mesh.material));
            }
        }
        out
    }
}

impl Camera {
    /// A camera that frames `bounds`: looking at the box's centre from far enough back that the
    /// whole box fits the vertical field of view, in a three-quarter view from above (45° round
    /// from +Z towards +X, 25° up), as Blender's default camera looks at its default cube. A
    /// front view (down −Z) would see a floor edge-on and, for a file lit from one side, often
    /// only the faces the light does not reach (Blender's startup scene, exported without its
    /// camera, rendered black: docs/scenes.md, "Files from Blender").
    pub fn framing(bounds: Aabb) -> Self {
        let mut cam = Camera::default();
        if bounds.is_empty() {
            cam.transform = Mat4::from_translation(Vec3::new(0.0, 0.0, 5.0));
            return cam;
        }
        let center = bounds.center();
        let radius = (bounds.extent().length() * 0.5).max(1e-3);
        let dist = radius / (cam.yfov * 0.5).sin();
        let (azimuth, elevation) = (45f32.to_radians(), 25f32.to_radians());
        let towards_eye = Vec3::new(
            azimuth.sin() * elevation.cos(),
            elevation.sin(),
            azimuth.cos() * elevation.cos(),
        );
        let eye = center + towards_eye * dist;
        cam.transform = glam::camera::rh::view::look_at_mat4(eye, center, Vec3::Y).inverse();
        cam.znear = (dist - radius).max(radius * 1e-3);
        cam.zfar = Some(dist + radius * 2.0);
        cam
    }

    pub fn position(&self) -> Vec3 {
        self.transform.w_axis.truncate()
    }

    /// Camera-from-world transform.
    pub fn view(&self) -> Mat4 {
        self.transform.inverse()
    }

    /// The pixel (x right, y down, continuous) that world point `p` lands on in a
    /// `width`×`height` image, or `None` when it is behind the camera.
    pub fn project_to_pixel(&self, p: Vec3, width: u32, height: u32) -> Option<Vec2> {
        let q = self.view().transform_point3(p);
        if q.z >= 0.0 {
            return None;
        }
        let aspect = width as f32 / height as f32;
        let t = (self.yfov * 0.5).tan();
        let ndc = Vec2::new(q.x / (-q.z * t * aspect), q.y / (-q.z * t));
        Some(Vec2::new(
            (ndc.x + 1.0) * 0.5 * width as f32,
            (1.0 - ndc.y) * 0.5 * height as f32,
        ))
    }
}
