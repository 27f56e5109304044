#version 460
// Eye G-buffer, fragment stage: what the later passes need to shade this pixel.
//   position: camera-relative world position (w = 1 where geometry was drawn, 0 = background)
//   normal:   unit shading normal turned towards the viewer; w = +1 if that is the side the
//             mesh's normals face, -1 if it was turned (refraction needs the true side)
//   albedo:   Lambertian reflectance times the base-colour texture (linear)
//   material: index into the material buffer
#include "shared.glsl"

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
    out_position = vec4(v_position, 1.0);
    out_normal = vec4(n, side);
    out_albedo = vec4(albedo, 1.0);
    out_material = draw.material.x;
}
