#version 460
// Deferred direct illumination: for every eye G-buffer pixel, the sum over lights of
// BSDF * irradiance * cos * visibility, plus emission. Visibility is a 3x3 grid of hardware
// depth-compare (bilinear PCF) lookups in the light's shadow-atlas layer.
#include "shared.glsl"
#include "lights.glsl"
#include "material.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform Frame { FrameUniforms frame; };
layout(std430, set = 0, binding = 1) readonly buffer Materials { GpuMaterial materials[]; };
layout(std430, set = 0, binding = 2) readonly buffer Lights { GpuLight lights[]; };
layout(std430, set = 0, binding = 3) readonly buffer Views { ShadowView shadow_views[]; };
layout(set = 0, binding = 4) uniform sampler2D g_position;
layout(set = 0, binding = 5) uniform sampler2D g_normal;
layout(set = 0, binding = 6) uniform sampler2D g_albedo;
layout(set = 0, binding = 7) uniform usampler2D g_material;
layout(set = 0, binding = 8) uniform sampler2DArrayShadow shadow_atlas;
layout(set = 0, binding = 9, rgba32f) uniform writeonly image2D out_radiance;

float shadow_visibility(GpuLight light, vec3 p, vec3 n, vec3 wi) {
    // Normal offset: push the lookup point off the surface by about one shadow texel,
    // measured at the point's distance from the light (perspective) or absolutely (ortho).
    ShadowView first = shadow_views[light.shadow.y];
    float dist = first.params.y > 0.5 ? 1.0 : length(light.position.xyz - p);
    float texel = first.params.x * dist;
    float cos_t = clamp(dot(n, wi), 0.0, 1.0);
    float sin_t = sqrt(max(0.0, 1.0 - cos_t * cos_t));
    vec3 q = p + n * (1.5 * texel * max(sin_t, 0.2));
    // The face is chosen for the point actually looked up (cube faces overlap by a margin
    // that covers the offset and the PCF footprint, see lighting.rs).
    uint vi = shadow_view_index(light, q);
    ShadowView view = shadow_views[vi];
    vec4 clip = view.view_proj * vec4(q, 1.0);
    if (clip.w <= 0.0) {
        return 1.0;
    }
    vec3 ndc = clip.xyz / clip.w;
    vec2 uv = ndc.xy * 0.5 + 0.5;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0))) || ndc.z > 1.0) {
        // Outside the light's view: spot cones and fitted directional frusta cover every
        // point the light reaches, so a point outside is not lit through this view.
        return light.shadow.x == LIGHT_SPOT ? 0.0 : 1.0;
    }
    float step_uv = frame.params.x;
    float sum = 0.0;
    for (int y = -1; y <= 1; ++y) {
        for (int x = -1; x <= 1; ++x) {
            vec2 o = vec2(x, y) * step_uv;
            sum += texture(shadow_atlas, vec4(uv + o, float(vi), ndc.z));
        }
    }
    return sum / 9.0;
}

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = ivec2(frame.counts.zw);
    if (px.x >= size.x || px.y >= size.y) {
        return;
    }
    vec4 pos = texelFetch(g_position, px, 0);
    if (pos.w == 0.0) {
        imageStore(out_radiance, px, vec4(0.0, 0.0, 0.0, 1.0));
        return;
    }
    vec3 p = pos.xyz;
    vec4 nw = texelFetch(g_normal, px, 0);
    vec3 n = normalize(nw.xyz);
    // The BSDF decides entering/leaving a dielectric from the mesh's own side.
    vec3 n_mesh = n * (nw.w < 0.0 ? -1.0 : 1.0);
    vec3 albedo = texelFetch(g_albedo, px, 0).rgb;
    GpuMaterial m = materials[texelFetch(g_material, px, 0).x];
    Bsdf bsdf = material_bsdf(m, albedo);
    vec3 wo = normalize(-p);

    vec3 radiance = m.emission.rgb;
    for (uint i = 0u; i < frame.counts.x; ++i) {
        GpuLight light = lights[i];
        LightSample s = sample_light(light, p);
        float cos_i = dot(n, s.wi);
        if (cos_i <= 0.0 || all(equal(s.irradiance, vec3(0.0)))) {
            continue;
        }
        float vis = light.shadow.z > 0u ? shadow_visibility(light, p, n, s.wi) : 1.0;
        if (vis <= 0.0) {
            continue;
        }
        vec3 f = bsdf_eval(bsdf, wo, s.wi, n_mesh, n_mesh);
        radiance += f * s.irradiance * cos_i * vis;
    }
    imageStore(out_radiance, px, vec4(radiance, 1.0));
}
