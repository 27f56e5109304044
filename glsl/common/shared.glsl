// Struct layouts shared with the CPU. Each struct here has a `#[repr(C)]` twin in
// src/layout/mod.rs with compile-time size/offset asserts; tests/layouts.rs checks both against the
// offsets the compiled SPIR-V declares. Everything is camera-relative world space: positions
// have the camera position subtracted on the CPU in double precision, so scenes far from the
// origin keep their precision.
#ifndef SHARED_GLSL
#define SHARED_GLSL

#include "shared_constants.glsl"

// Per-frame camera data (uniform buffer, std140).
struct FrameUniforms {
    mat4 view_proj;      // camera-relative world -> clip
    mat4 inv_view_proj;  // clip -> camera-relative world
    vec4 camera_pos;     // absolute world position of the camera (xyz)
    uvec4 counts;        // x: lights, y: shadow views, z: width, w: height
    vec4 params;         // x: shadow texel size (1/res), y: scene scale (m), z, w: unused
    vec4 viewer;         // w = 1: camera-relative viewer position (xyz); w = 0: unit direction
                         // towards a viewer at infinity (orthographic light views)
};

// Where the environment cube map was rendered from, for its lookups (uniform buffer, std140).
struct EnvironmentUniforms {
    vec4 centre;      // xyz: camera-relative centre of the cube map; w: weight of the indirect
                      // cube (1, or 0 in the direct-only debug view)
    vec4 bounds_min;  // xyz: camera-relative scene bounds, the box lookups are projected onto
    vec4 bounds_max;
};

// An über-BSDF material (storage buffer, std430).
struct GpuMaterial {
    vec4 lambertian;    // rgb: rho_L; a: unused
    vec4 glossy;        // rgb: rho_S; a: exponent (1e30 for a perfect mirror)
    vec4 transmission;  // rgb: rho_t; a: eta
    vec4 emission;      // rgb: W/(m^2 sr); a: unused
    uvec4 flags;        // x: MATERIAL_FRESNEL | MATERIAL_TEXTURED | MATERIAL_DOUBLE_SIDED
};

// A punctual light (storage buffer, std430).
struct GpuLight {
    vec4 position;    // xyz: camera-relative position; w: unused
    vec4 direction;   // xyz: unit direction light travels; w: cos(outer cone)
    vec4 intensity;   // rgb: W/sr (point, spot) or W/m^2 (directional); w: cos(inner cone)
    uvec4 shadow;     // x: kind (LIGHT_*); y: first shadow view; z: shadow view count; w: unused
};

// One shadow-map view (storage buffer, std430): a layer of the shadow atlas.
struct ShadowView {
    mat4 view_proj;   // camera-relative world -> light clip
    vec4 params;      // x: world-space texel size at unit distance, y: is_ortho, z: least
                      // lookup offset (m; ortho: 128 depth steps), w: unused
};

// One light view of the light G-buffer / bounce map (storage buffer, std430).
struct BounceView {
    mat4 inv_view_proj;  // light clip -> camera-relative world
    vec4 light;          // xyz: camera-relative light position (perspective views); w: unused
    vec4 axis;           // xyz: unit direction light travels (spot axis, directional); w: cos(outer)
    vec4 intensity;      // rgb: W/sr, or W/m^2 for directional, times the view's exact-flux
                         // normalisation; w: cos(inner)
    vec4 params;         // x: texel side on the plane at unit distance (perspective) or in m
                         // (ortho); y: unused; zw: that plane's coordinates of the outer corner
                         // of texel (0, 0) (the parent view's plane, for caustic views)
    uvec4 texels;        // x: width; y: height; z: first bounce-map index; w: light seed
    uvec4 kind;          // x: light kind (LIGHT_*); y: role (BOUNCE_VIEW_*); z: parent view
                         // (caustic views); w: which of the light's views (random-number key)
};

// Per-draw push constants of the raster passes (128 bytes: the guaranteed minimum).
struct DrawPush {
    mat4 model;       // object -> camera-relative world (eye) or object -> light clip (shadow)
    vec4 normal0;     // xyz: columns of the object -> world normal matrix (inverse transpose);
    vec4 normal1;     // w: 0, or (translucent pass, convex mesh) the mesh's centre, object space
    vec4 normal2;
    uvec4 material;   // x: material index; z: 1 + the root of the BVH over the mesh's own
                      // triangles (translucent pass; 0: none); w: 1 when that mesh is convex
                      // (src/passes/translucent/object_bvh.rs); y: 0
};

// A node of the BVH over one delta mesh's own triangles, object space (storage buffer, std430;
// src/passes/translucent/object_bvh.rs).
struct ObjectNode {
    vec3 lo;     // low corner
    uint first;  // inner node: its first child (the second is the next); leaf: first triangle
    vec3 hi;     // high corner
    uint count;  // a leaf's triangle count (0: inner node)
};

// One triangle of a delta mesh, object space, with its vertices' normals (storage buffer, std430).
struct ObjectTriangle {
    vec4 p0;
    vec4 p1;
    vec4 p2;
    vec4 n0;
    vec4 n1;
    vec4 n2;
};

// What one value check counted in one buffer (storage buffer, std430; src/passes/value_check.rs).
struct ValueCounters {
    uint non_finite;  // NaN or +-Inf
    uint negative;    // finite and below zero (not -0.0), where a negative value is wrong
    uint values;      // values read
    uint unused;
};

const uint MATERIAL_FRESNEL = 1u;
const uint MATERIAL_TEXTURED = 2u;
const uint MATERIAL_DOUBLE_SIDED = 4u;

#endif
