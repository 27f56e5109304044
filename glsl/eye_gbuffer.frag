#version 460
// Eye G-buffer, fragment stage: what the later passes need to shade this pixel.
//   position: camera-relative world position (w = 1 where geometry was drawn, 0 = background)
//   normal:   unit shading normal turned towards the viewer; the sign of w is + if that is the
//             side the mesh's normals face, - if it was turned (refraction needs the true
//             side); |w| - 2 is the face normal's second octahedral coordinate
//   albedo:   Lambertian reflectance times the base-colour texture (linear); a: the face
//             normal's first octahedral coordinate. The face normal (the triangle's plane,
//             turned towards the viewer: packing.glsl, gbuffer_face_normal) lets the bounce map
//             place a photon anywhere inside its texel on the triangle itself.
//   material: index into the material buffer
#include "shared.glsl"
#include "packing.glsl"

layout(set = 0, binding = 0) uniform Frame { FrameUniforms frame; };
layout(std430, set = 0, binding = 1) readonly buffer Materials { GpuMaterial materials[]; };
layout(set = 1, binding = 0) uniform sampler2D base_color;
layout(push_constant) uniform Push { DrawPush draw; };

layout(location = 0) in vec3 v_position;
layout(location = 1) in vec3 v_normal;
layout(location = 2) in vec2 v_uv;

layout(location = 0) out vec4 out_position;
layout(location = 1) out vec4 out_normal;
layout(location = 2) out vec4 out_albedo;
layout(location = 3) out uint out_material;

void main() {
    GpuMaterial m = materials[draw.material.x];
    vec3 n = v_normal;
    float len = length(n);
    // Degenerate interpolated normal (opposite vertex normals): fall back to the face normal.
    vec3 face = cross(dFdx(v_position), dFdy(v_position));
    if (!(len > 1e-6)) {
        n = face;
        len = length(n);
    }
    n = len > 0.0 ? n / len : vec3(0.0, 1.0, 0.0);
    // Shade the side the viewer sees (the camera, or the light of a light G-buffer).
    vec3 to_viewer = frame.viewer.w > 0.5 ? frame.viewer.xyz - v_position : frame.viewer.xyz;
    float side = 1.0;
    if (dot(n, to_viewer) < 0.0) {
        n = -n;
        side = -1.0;
    }
    vec3 albedo = m.lambertian.rgb;
    if ((m.flags.x & MATERIAL_TEXTURED) != 0u) {
        albedo *= texture(base_color, v_uv).rgb;
    }
    float face_len = length(face);
    vec3 f = face_len > 0.0 ? face / face_len : n;
    if (dot(f, to_viewer) < 0.0) {
        f = -f;
    }
    vec2 oct = oct_encode(f);
    out_position = vec4(v_position, 1.0);
    out_normal = vec4(n, side * (2.0 + oct.y));
    out_albedo = vec4(albedo, oct.x);
    out_material = draw.material.x;
}
