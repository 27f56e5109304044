#version 460
// Upsample (--subsample N > 1): joint bilateral upsampling of the low-resolution photon
// estimate against the full-resolution eye G-buffer, applying the full-resolution BSDF.
//   indirect = (c_L/π)(full-res pixel) · Ẽ + G̃
// where c_L/π is the direct pass's `lambert`, and Ẽ and G̃ are the low-resolution
// irradiance-like sum Σ Φκ and glossy radiance, interpolated from the 2×2 nearest
// low-resolution samples with weights
//   bilinear × max(0, n·n_s)^NORMAL_POWER × exp(−|n·(p_s − p)| / (DEPTH_SIGMA · |p|)),
// normalised. When every weight vanishes, the sample most similar in geometry is used alone
// (the bilinear-nearest among equals; nothing when all four are background). With
// push.joint == 0 the geometric weights are 1: a plain bilinear upsample (ispm sweep's
// "upsampling off").
//
// An invocation shades a block of up to BLOCK×BLOCK pixels that share their four samples (the
// pixels between four sample centres: a "cell"), so it reads the samples once, not once per
// pixel: on lavapipe every read costs a lane its address arithmetic and a gather, and the
// sixteen sample reads were most of the pass. Invocation (x, y) takes cell x / k − 1 (the
// pixels left of the first centre belong to cell −1), block x mod k of it, with k = ⌈N / BLOCK⌉
// blocks per cell side (`passes/upsample.rs` dispatches them).
#include "shared.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform sampler2D g_position;
layout(set = 0, binding = 1) uniform sampler2D g_normal;
// rgb: the pixel's c_L/π; a: 1 where its BSDF faces the eye (direct.comp).
layout(set = 0, binding = 2) uniform sampler2D lambert;
layout(set = 0, binding = 3) uniform sampler2D low_irradiance;
layout(set = 0, binding = 4) uniform sampler2D low_glossy;
layout(set = 0, binding = 5, rgba32f) uniform writeonly image2D indirect;

// The block's side, ⌈N / ⌈N / UPSAMPLE_BLOCK⌉⌉ (`passes/upsample.rs`): a constant, so that
// llvmpipe unrolls the pixel loop.
layout(constant_id = SPEC_ID_UPSAMPLE_BLOCK) const int BLOCK = 4;

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

// One store per pixel and no second read of a sample: llvmpipe runs both sides of a branch (the
// lanes masked), so an early return, a second store or a fallback's read costs every pixel.
void main() {
    int n = int(push.subsample);
    int k = (n + BLOCK - 1) / BLOCK;
    ivec2 id = ivec2(gl_GlobalInvocationID.xy);
    ivec2 cell = id / k - 1;
    ivec2 last = ivec2(push.low_size) - 1;
    if (cell.x > last.x || cell.y > last.y) {
        return;
    }
    // The four samples the cell's pixels interpolate: cell + (i, j), clamped to the image.
    vec4 sample_pos[4];
    vec3 sample_n[4];
    vec4 sample_irradiance[4];
    vec3 sample_glossy[4];
    for (int q = 0; q < 4; ++q) {
        ivec2 low = clamp(cell + ivec2(q & 1, q >> 1), ivec2(0), last);
        ivec2 s = subsample_centre(low);
        sample_pos[q] = texelFetch(g_position, s, 0);
        sample_n[q] = normalize(texelFetch(g_normal, s, 0).xyz);
        sample_irradiance[q] = texelFetch(low_irradiance, low, 0);
        sample_glossy[q] = texelFetch(low_glossy, low, 0).rgb;
    }
    // This invocation's pixels: its block of the cell, within the image.
    ivec2 cell_first = cell * n + n / 2;
    ivec2 first = cell_first + (id % k) * BLOCK;
    ivec2 end = min(min(cell_first + n, first + BLOCK), ivec2(push.size));
    float n_f = float(n);
    for (int by = 0; by < BLOCK; ++by) {
        for (int bx = 0; bx < BLOCK; ++bx) {
            ivec2 px = first + ivec2(bx, by);
            if (any(lessThan(px, ivec2(0))) || any(greaterThanEqual(px, end))) {
                continue;
            }
            vec4 pos = texelFetch(g_position, px, 0);
            vec3 nrm = normalize(texelFetch(g_normal, px, 0).xyz);
            float dist = max(length(pos.xyz), 1e-6);
            // exp(−x/(σ·dist)) = exp2(−x·k_depth)
            float k_depth = 1.4426950408889634 / (push.depth_sigma * dist);
            // Bilinear position between the samples: sample i sits at full-res pixel i·N + N/2.
            // From the integer offset in the cell, so that it lies in [0, 1) whatever the
            // device's division rounds.
            vec2 t = vec2(px - cell_first) / n_f;

            vec4 irradiance = vec4(0.0);
            vec3 glossy = vec3(0.0);
            float total = 0.0;
            // The sample most similar in geometry (none while all four are background).
            float best_score = -1.0;
            vec4 best_irradiance = vec4(0.0);
            vec3 best_glossy = vec3(0.0);
            for (int q = 0; q < 4; ++q) {
                if (sample_pos[q].w == 0.0) {
                    continue;
                }
                // max(0, n·n_s)^(2^UPSAMPLE_NORMAL_POWER_LOG2), by squaring (cheaper than pow
                // on llvmpipe).
                float normal_w = max(dot(nrm, sample_n[q]), 0.0);
                for (uint p = 0u; p < UPSAMPLE_NORMAL_POWER_LOG2; ++p) {
                    normal_w *= normal_w;
                }
                float plane = abs(dot(nrm, sample_pos[q].xyz - pos.xyz));
                float depth_w = exp2(-plane * k_depth);
                float geometry = push.joint != 0u ? normal_w * depth_w : 1.0;
                float bilinear = ((q & 1) == 0 ? 1.0 - t.x : t.x)
                               * ((q >> 1) == 0 ? 1.0 - t.y : t.y);
                float w = bilinear * geometry;
                irradiance += w * sample_irradiance[q];
                glossy += w * sample_glossy[q];
                total += w;
                // Most similar geometry; among equals (all zero), the bilinear-nearest.
                float score = geometry + 1e-6 * bilinear;
                if (score > best_score) {
                    best_score = score;
                    best_irradiance = sample_irradiance[q];
                    best_glossy = sample_glossy[q];
                }
            }
            // Normalised; when every weight vanishes, the most similar sample alone.
            if (total > 1e-6) {
                irradiance /= total;
                glossy /= total;
            } else {
                irradiance = best_irradiance;
                glossy = best_glossy;
            }
            // The full-resolution Lambertian BSDF (with its Fresnel factor, which depends on ωo
            // only), made by the direct pass; nothing where the BSDF does not face the eye.
            vec4 c_l = texelFetch(lambert, px, 0);
            vec3 radiance = c_l.a != 0.0 ? c_l.rgb * irradiance.rgb + glossy : vec3(0.0);
            // The background (pos.w = 0) gets nothing.
            imageStore(indirect, px, pos.w != 0.0 ? vec4(radiance, irradiance.a) : vec4(0.0));
        }
    }
}
