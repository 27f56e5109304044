#version 460
// Denoise (src/passes/denoise.rs): an edge-avoiding à-trous wavelet filter (Dammertz et al.,
// HPG 2010) over the global photons' share of the estimate (the support pass's G / f), guided
// by the eye G-buffer; caustic photons are left alone. Three modes (push.mode):
//   SPLIT   total −= global           (total keeps the caustic photons' share)
//   FILTER  dst = one level of the filter over src
//   MERGE   total += src               (the filtered global share back)
// At --subsample N > 1 the images are the low-resolution ones, each pixel standing for the
// G-buffer pixel at the centre of its N×N block (as in support.comp). Level k convolves with
// the 5×5 B3-spline kernel h = (1, 4, 6, 4, 1)/16 spread over taps 2^k pixels apart, each tap
// q weighted against the centre p by
//   h(i)·h(j) · max(0, n_p·n_q)^NORMAL_POWER · exp(−|n_p·(x_q − x_p)| / (PLANE_SIGMA·|x_p|)
//                                                 − |a_q − a_p|² / ALBEDO_SIGMA²)
// (NORMAL_POWER = 2^DENOISE_NORMAL_POWER_LOG2, raised by squaring; both exponentials in one exp2:
// together 1.26× cheaper than pow and two exp on llvmpipe)
// (normal similarity, distance from p's tangent plane relative to p's distance from the eye,
// albedo similarity), normalised. Background pixels (position.w = 0) are neither filtered nor
// used, and a level filters a pixel only while its step is at most push.reach × the pixel's
// mean global kernel radius on screen (the blotches' scale; src's alpha holds that radius in
// metres).
// There is no colour (luminance) stop: the noise to remove is a blotch of many pixels, which
// a colour stop would keep.
#include "shared.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform sampler2D g_position;
layout(set = 0, binding = 1) uniform sampler2D g_normal;
layout(set = 0, binding = 2) uniform sampler2D g_albedo;
layout(set = 0, binding = 3, rgba32f) uniform readonly image2D src;
layout(set = 0, binding = 4, rgba32f) uniform writeonly image2D dst;
layout(set = 0, binding = 5, rgba32f) uniform image2D total;

const uint SPLIT = 0u;
const uint FILTER = 1u;
const uint MERGE = 2u;

layout(push_constant) uniform Push {
    uvec2 size;       // the images'
    uvec2 g_size;     // the eye G-buffer's
    int step;         // FILTER: 2^level, the distance between taps, in pixels
    uint subsample;
    uint mode;
    float plane_sigma;
    float albedo_sigma;
    float pixel_angle;  // 2·tan(fov/2)/height: one image pixel's size per metre of distance
    float reach;        // a level filters while its step is at most reach × the kernel radius
} push;

// The G-buffer pixel image pixel `id` shades.
ivec2 shaded(ivec2 id) {
    int n = int(push.subsample);
    return min(id * n + n / 2, ivec2(push.g_size) - 1);
}

const float H[3] = float[3](6.0 / 16.0, 4.0 / 16.0, 1.0 / 16.0);

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (px.x >= int(push.size.x) || px.y >= int(push.size.y)) {
        return;
    }
    vec4 centre = imageLoad(src, px);
    if (push.mode != FILTER) {
        vec4 t = imageLoad(total, px);
        float s = push.mode == SPLIT ? -1.0 : 1.0;
        imageStore(total, px, vec4(t.rgb + s * centre.rgb, t.a));
        return;
    }
    ivec2 gp = shaded(px);
    vec4 pos = texelFetch(g_position, gp, 0);
    if (pos.w == 0.0) {
        imageStore(dst, px, centre);
        return;
    }
    float dist = max(length(pos.xyz), 1e-6);
    // Up to the scale of the kernels that made this pixel's estimate: a level whose taps are
    // further apart than reach × their mean radius (alpha: r in metres, from support.comp) on
    // screen leaves the pixel as it is. No global photon here (r = 0): nothing to filter.
    float r_px = centre.a / (dist * push.pixel_angle);
    if (!(float(push.step) <= push.reach * r_px)) {
        imageStore(dst, px, centre);
        return;
    }
    vec3 n = normalize(texelFetch(g_normal, gp, 0).xyz);
    vec3 albedo = texelFetch(g_albedo, gp, 0).rgb;
    ivec2 last = ivec2(push.size) - 1;
    const float LOG2_E = 1.4426950408889634;
    float k_plane = LOG2_E / (push.plane_sigma * dist);
    float k_albedo = LOG2_E / (push.albedo_sigma * push.albedo_sigma);

    vec3 sum = vec3(0.0);
    float wsum = 0.0;
    for (int j = -2; j <= 2; ++j) {
        for (int i = -2; i <= 2; ++i) {
            ivec2 q = px + ivec2(i, j) * push.step;
            if (any(lessThan(q, ivec2(0))) || any(greaterThan(q, last))) {
                continue;
            }
            ivec2 gq = shaded(q);
            vec4 pos_q = texelFetch(g_position, gq, 0);
            if (pos_q.w == 0.0) {
                continue;
            }
            vec3 n_q = normalize(texelFetch(g_normal, gq, 0).xyz);
            // max(0, n·n_q)^(2^DENOISE_NORMAL_POWER_LOG2), by squaring.
            float normal_w = max(dot(n, n_q), 0.0);
            for (uint s = 0u; s < DENOISE_NORMAL_POWER_LOG2; ++s) {
                normal_w *= normal_w;
            }
            float plane = abs(dot(n, pos_q.xyz - pos.xyz));
            vec3 da = texelFetch(g_albedo, gq, 0).rgb - albedo;
            float exponent = plane * k_plane + dot(da, da) * k_albedo;
            float w = H[abs(i)] * H[abs(j)] * normal_w * exp2(-exponent);
            sum += w * imageLoad(src, q).rgb;
            wsum += w;
        }
    }
    // The centre's own weight is H[0]² > 0, so wsum > 0.
    imageStore(dst, px, vec4(sum / wsum, centre.a));
}
