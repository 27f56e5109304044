#version 460
// Upsample (--subsample N > 1): joint bilateral upsampling of the low-resolution photon
// estimate against the full-resolution eye G-buffer, applying the full-resolution BSDF.
//   indirect = (c_L/π)(full-res pixel) · Ẽ + G̃
// where Ẽ and G̃ are the low-resolution irradiance-like sum Σ Φκ and glossy radiance,
// interpolated from the 2×2 nearest low-resolution samples with weights
//   bilinear × max(0, n·n_s)^NORMAL_POWER × exp(−|n·(p_s − p)| / (DEPTH_SIGMA · |p|)),
// normalised. When every weight vanishes, the sample most similar in geometry is used alone
// (the bilinear-nearest among equals; nothing when all four are background). With
// push.joint == 0 the geometric weights are 1: a plain bilinear upsample (ispm sweep's
// "upsampling off").
#include "shared.glsl"
#include "material.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, set = 0, binding = 0) readonly buffer Materials { GpuMaterial materials[]; };
layout(set = 0, binding = 1) uniform sampler2D g_position;
layout(set = 0, binding = 2) uniform sampler2D g_normal;
layout(set = 0, binding = 3) uniform sampler2D g_albedo;
layout(set = 0, binding = 4) uniform usampler2D g_material;
layout(set = 0, binding = 5) uniform sampler2D low_irradiance;
layout(set = 0, binding = 6) uniform sampler2D low_glossy;
layout(set = 0, binding = 7, rgba32f) uniform writeonly image2D indirect;

layout(push_constant) uniform Push {
    uvec2 size;
    uvec2 low_size;
    uint subsample;
    float depth_sigma;
    uint joint;  // 0: plain bilinear (the geometric weights are 1)
} push;

// The full-resolution pixel a low-resolution sample shaded (photon_volumes_subsampled.frag).
ivec2 subsample_centre(ivec2 low) {
    int n = int(push.subsample);
    return min(low * n + n / 2, ivec2(push.size) - 1);
}

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (px.x >= int(push.size.x) || px.y >= int(push.size.y)) {
        return;
    }
    vec4 pos = texelFetch(g_position, px, 0);
    if (pos.w == 0.0) {
        imageStore(indirect, px, vec4(0.0));
        return;
    }
    vec3 n = normalize(texelFetch(g_normal, px, 0).xyz);
    float dist = max(length(pos.xyz), 1e-6);
    // exp(−x/(σ·dist)) = exp2(−x·k_depth)
    float k_depth = 1.4426950408889634 / (push.depth_sigma * dist);

    // Low-resolution coordinates of this pixel: sample i sits at full-res pixel i·N + N/2.
    float n_f = float(push.subsample);
    vec2 f = (vec2(px) - floor(n_f / 2.0)) / n_f;
    ivec2 base = ivec2(floor(f));
    vec2 t = f - vec2(base);
    ivec2 last = ivec2(push.low_size) - 1;

    vec4 irradiance = vec4(0.0);
    vec3 glossy = vec3(0.0);
    float total = 0.0;
    float best_score = -1.0;
    ivec2 best = ivec2(-1);
    for (int j = 0; j < 2; ++j) {
        for (int i = 0; i < 2; ++i) {
            ivec2 low = clamp(base + ivec2(i, j), ivec2(0), last);
            ivec2 s = subsample_centre(low);
            vec4 pos_s = texelFetch(g_position, s, 0);
            if (pos_s.w == 0.0) {
                continue;
            }
            vec3 n_s = normalize(texelFetch(g_normal, s, 0).xyz);
            // max(0, n·n_s)^(2^UPSAMPLE_NORMAL_POWER_LOG2), by squaring (cheaper than pow on
            // llvmpipe).
            float normal_w = max(dot(n, n_s), 0.0);
            for (uint p = 0u; p < UPSAMPLE_NORMAL_POWER_LOG2; ++p) {
                normal_w *= normal_w;
            }
            float plane = abs(dot(n, pos_s.xyz - pos.xyz));
            float depth_w = exp2(-plane * k_depth);
            float geometry = push.joint != 0u ? normal_w * depth_w : 1.0;
            float bilinear = (i == 0 ? 1.0 - t.x : t.x) * (j == 0 ? 1.0 - t.y : t.y);
            float w = bilinear * geometry;
            irradiance += w * texelFetch(low_irradiance, low, 0);
            glossy += w * texelFetch(low_glossy, low, 0).rgb;
            total += w;
            // Most similar geometry; among equals (all zero), the bilinear-nearest.
            float score = geometry + 1e-6 * bilinear;
            if (score > best_score) {
                best_score = score;
                best = low;
            }
        }
    }
    if (total > 1e-6) {
        irradiance /= total;
        glossy /= total;
    } else if (best.x >= 0) {
        irradiance = texelFetch(low_irradiance, best, 0);
        glossy = texelFetch(low_glossy, best, 0).rgb;
    } else {
        imageStore(indirect, px, vec4(0.0));
        return;
    }

    // The full-resolution Lambertian BSDF (with its Fresnel factor, which depends on ωo only).
    GpuMaterial m = materials[texelFetch(g_material, px, 0).x];
    Bsdf bsdf = material_bsdf(m, texelFetch(g_albedo, px, 0).rgb);
    vec3 radiance = vec3(0.0);
    BsdfOriented o;
    if (bsdf_orient(bsdf, normalize(-pos.xyz), n, n, o)) {
        vec3 c[4];
        bsdf_lobe_reflectances(bsdf, o, c);
        radiance = c[LOBE_LAMBERTIAN] * (1.0 / PI) * irradiance.rgb + glossy;
    }
    imageStore(indirect, px, vec4(radiance, irradiance.a));
}
