#version 460
// Environment cube map, fragment stage: the opaque scene seen from the cube's centre
// (frame.viewer), shaded forward with shadowed direct light plus emission. Drawn with the eye
// G-buffer's vertex stage, one face's FrameUniforms at a time.
#include "shared.glsl"
#include "material.glsl"
#include "forward.glsl"

layout(set = 0, binding = 0) uniform Frame { FrameUniforms frame; };
layout(std430, set = 0, binding = 1) readonly buffer Materials { GpuMaterial materials[]; };
layout(std430, set = 0, binding = 2) readonly buffer Lights { GpuLight lights[]; };
layout(std430, set = 0, binding = 3) readonly buffer Views { ShadowView shadow_views[]; };
layout(set = 0, binding = 4) uniform sampler2DArrayShadow shadow_atlas;
layout(set = 1, binding = 0) uniform sampler2D base_color;
layout(push_constant) uniform Push { DrawPush draw; };

#include "shadows.glsl"

layout(location = 0) in vec3 v_position;
layout(location = 1) in vec3 v_normal;
layout(location = 2) in vec2 v_uv;

layout(location = 0) out vec4 out_radiance;

void main() {
    GpuMaterial m = materials[draw.material.x];
    vec3 p = v_position;
    float side;
    vec3 n = face_viewer(surface_normal(v_normal, p), frame.viewer.xyz - p, side);
    vec3 albedo = m.lambertian.rgb;
    if ((m.flags.x & MATERIAL_TEXTURED) != 0u) {
        albedo *= texture(base_color, v_uv).rgb;
    }
    Bsdf bsdf = material_bsdf(m, albedo);
    vec3 wo = normalize(frame.viewer.xyz - p);
    vec3 radiance = material_emission(m, side) + direct_light(bsdf, p, n, n * side, wo);
    out_radiance = vec4(radiance, 1.0);
}
