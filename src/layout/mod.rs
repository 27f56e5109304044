//! The `#[repr(C)]` twins of the structs in `glsl/common/shared.glsl`, with compile-time size
//! and offset asserts. `tests/layouts.rs` checks both sides against the member offsets the
//! compiled SPIR-V declares, so a change on one side alone fails the build or the tests.
//! [`shared_constants`]: the constants both sides read (`build.rs` writes their GLSL twin).

/// Constants shared with GLSL (generated into `shared_constants.glsl` by `build.rs`).
pub mod shared_constants {
    include!("shared_constants.rs");
}

use bytemuck::{Pod, Zeroable};
use core::mem::{offset_of, size_of};
use glam::{Mat4, UVec4, Vec4};

/// `FrameUniforms` (uniform buffer, std140).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct FrameUniforms {
    pub view_proj: Mat4,
    pub inv_view_proj: Mat4,
    pub camera_pos: Vec4,
    pub counts: UVec4,
    pub params: Vec4,
    pub viewer: Vec4,
}
const _: () = assert!(size_of::<FrameUniforms>() == 192);
const _: () = assert!(offset_of!(FrameUniforms, inv_view_proj) == 64);
const _: () = assert!(offset_of!(FrameUniforms, camera_pos) == 128);
const _: () = assert!(offset_of!(FrameUniforms, counts) == 144);
const _: () = assert!(offset_of!(FrameUniforms, params) == 160);
const _: () = assert!(offset_of!(FrameUniforms, viewer) == 176);

/// `BounceView` (storage buffer, std430): one light view of the light G-buffer and bounce map.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct BounceView {
    pub inv_view_proj: Mat4,
    pub light: Vec4,
    pub axis: Vec4,
    pub intensity: Vec4,
    pub params: Vec4,
    pub texels: UVec4,
    pub kind: UVec4,
}
const _: () = assert!(size_of::<BounceView>() == 160);
const _: () = assert!(offset_of!(BounceView, light) == 64);
const _: () = assert!(offset_of!(BounceView, axis) == 80);
const _: () = assert!(offset_of!(BounceView, intensity) == 96);
const _: () = assert!(offset_of!(BounceView, params) == 112);
const _: () = assert!(offset_of!(BounceView, texels) == 128);
const _: () = assert!(offset_of!(BounceView, kind) == 144);

/// `GpuMaterial` (storage buffer, std430).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuMaterial {
    pub lambertian: Vec4,
    pub glossy: Vec4,
    pub transmission: Vec4,
    pub emission: Vec4,
    pub flags: UVec4,
}
const _: () = assert!(size_of::<GpuMaterial>() == 80);
const _: () = assert!(offset_of!(GpuMaterial, glossy) == 16);
const _: () = assert!(offset_of!(GpuMaterial, transmission) == 32);
const _: () = assert!(offset_of!(GpuMaterial, emission) == 48);
const _: () = assert!(offset_of!(GpuMaterial, flags) == 64);

/// `GpuLight` (storage buffer, std430).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuLight {
    pub position: Vec4,
    pub direction: Vec4,
    pub intensity: Vec4,
    pub shadow: UVec4,
}
const _: () = assert!(size_of::<GpuLight>() == 64);
const _: () = assert!(offset_of!(GpuLight, direction) == 16);
const _: () = assert!(offset_of!(GpuLight, intensity) == 32);
const _: () = assert!(offset_of!(GpuLight, shadow) == 48);

/// `ShadowView` (storage buffer, std430).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct ShadowView {
    pub view_proj: Mat4,
    pub params: Vec4,
}
const _: () = assert!(size_of::<ShadowView>() == 80);
const _: () = assert!(offset_of!(ShadowView, params) == 64);

/// `EnvironmentUniforms` (uniform buffer, std140).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct EnvironmentUniforms {
    /// xyz: camera-relative centre of the cube maps; w: the indirect cube's weight (1, or 0 in
    /// the direct-only debug view).
    pub centre: Vec4,
    pub bounds_min: Vec4,
    pub bounds_max: Vec4,
}
const _: () = assert!(size_of::<EnvironmentUniforms>() == 48);
const _: () = assert!(offset_of!(EnvironmentUniforms, bounds_min) == 16);
const _: () = assert!(offset_of!(EnvironmentUniforms, bounds_max) == 32);

/// `DrawPush` (push constants of the raster passes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct DrawPush {
    pub model: Mat4,
    pub normal0: Vec4,
    pub normal1: Vec4,
    pub normal2: Vec4,
    /// x: material index; z: 1 + the root of the mesh's own BVH (the translucent pass sets it;
    /// 0: none); w: 1 when that mesh is convex, its centre then in the `normal*.w`
    /// (`passes/translucent/object_bvh.rs`, "Convex meshes"); y: 0.
    pub material: UVec4,
}
const _: () = assert!(size_of::<DrawPush>() == 128);
const _: () = assert!(offset_of!(DrawPush, normal0) == 64);
const _: () = assert!(offset_of!(DrawPush, normal1) == 80);
const _: () = assert!(offset_of!(DrawPush, normal2) == 96);
const _: () = assert!(offset_of!(DrawPush, material) == 112);

/// `ObjectNode` (storage buffer, std430): a node of the BVH over one delta mesh's own
/// triangles, in object space (`passes/translucent/object_bvh.rs`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ObjectNode {
    /// The bounds' low corner.
    pub lo: [f32; 3],
    /// An inner node: its first child (the second is the next); a leaf: its first triangle.
    pub first: u32,
    /// The bounds' high corner.
    pub hi: [f32; 3],
    /// A leaf's triangle count (0: an inner node).
    pub count: u32,
}
const _: () = assert!(size_of::<ObjectNode>() == 32);
const _: () = assert!(offset_of!(ObjectNode, first) == 12);
const _: () = assert!(offset_of!(ObjectNode, hi) == 16);
const _: () = assert!(offset_of!(ObjectNode, count) == 28);

/// `ObjectTriangle` (storage buffer, std430): one triangle of a delta mesh, object space, with
/// its vertices' normals (w unused).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ObjectTriangle {
    pub p0: Vec4,
    pub p1: Vec4,
    pub p2: Vec4,
    pub n0: Vec4,
    pub n1: Vec4,
    pub n2: Vec4,
}
const _: () = assert!(size_of::<ObjectTriangle>() == 96);
const _: () = assert!(offset_of!(ObjectTriangle, p1) == 16);
const _: () = assert!(offset_of!(ObjectTriangle, p2) == 32);
const _: () = assert!(offset_of!(ObjectTriangle, n0) == 48);
const _: () = assert!(offset_of!(ObjectTriangle, n1) == 64);
const _: () = assert!(offset_of!(ObjectTriangle, n2) == 80);

/// `ValueCounters` (storage buffer, std430): what one value check counted in one buffer of a
/// frame (`passes/value_check.rs`), summed with atomics.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct ValueCounters {
    /// NaN or ±Inf values.
    pub non_finite: u32,
    /// Finite values below zero where a negative value is wrong (not -0.0).
    pub negative: u32,
    /// Values read.
    pub values: u32,
    pub unused: u32,
}
const _: () = assert!(size_of::<ValueCounters>() == 16);
const _: () = assert!(offset_of!(ValueCounters, negative) == 4);
const _: () = assert!(offset_of!(ValueCounters, values) == 8);
const _: () = assert!(offset_of!(ValueCounters, unused) == 12);

/// The interleaved vertex of every mesh (vertex attributes 0, 1, 2).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct Vertex {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    pub uv: [f32; 2],
}
const _: () = assert!(size_of::<Vertex>() == 32);
const _: () = assert!(offset_of!(Vertex, normal) == 12);
const _: () = assert!(offset_of!(Vertex, uv) == 24);

pub const MATERIAL_FRESNEL: u32 = 1;
pub const MATERIAL_TEXTURED: u32 = 2;
pub const MATERIAL_DOUBLE_SIDED: u32 = 4;

pub use crate::layout::shared_constants::{
    LIGHT_AREA_SAMPLE, LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT,
};

/// A shared struct's name and its members' (name, offset), for the SPIR-V layout test.
pub struct LayoutDescription {
    pub name: &'static str,
    pub size: usize,
    pub members: &'static [(&'static str, usize)],
}

macro_rules! describe {
    ($t:ident { $($m:ident),* }) => {
        LayoutDescription {
            name: stringify!($t),
            size: size_of::<$t>(),
            members: &[$((stringify!($m), offset_of!($t, $m))),*],
        }
    };
}

/// Every struct shared with GLSL.
pub const SHARED_LAYOUTS: &[LayoutDescription] = &[
    describe!(FrameUniforms {
        view_proj,
        inv_view_proj,
        camera_pos,
        counts,
        params,
        viewer
    }),
    describe!(BounceView {
        inv_view_proj,
        light,
        axis,
        intensity,
        params,
        texels,
        kind
    }),
    describe!(GpuMaterial {
        lambertian,
        glossy,
        transmission,
        emission,
        flags
    }),
    describe!(GpuLight {
        position,
        direction,
        intensity,
        shadow
    }),
    describe!(ShadowView { view_proj, params }),
    describe!(EnvironmentUniforms {
        centre,
        bounds_min,
        bounds_max
    }),
    describe!(ValueCounters {
        non_finite,
        negative,
        values,
        unused
    }),
    describe!(DrawPush {
        model,
        normal0,
        normal1,
        normal2,
        material
    }),
    describe!(ObjectNode {
        lo,
        first,
        hi,
        count
    }),
    describe!(ObjectTriangle {
        p0,
        p1,
        p2,
        n0,
        n1,
        n2
    }),
];
