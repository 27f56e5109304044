// Display transforms: exposure, then one of the operators below, then the sRGB transfer
// function. Operator ids are the TONEMAP_* constants shared with src/output/mod.rs.
#ifndef TONEMAP_GLSL
#define TONEMAP_GLSL
#include "shared_constants.glsl"

// Stephen Hill's fit of the ACES RRT + sRGB ODT ("ACES fitted").
vec3 aces_fitted(vec3 color) {
    const mat3 aces_in = mat3(
        0.59719, 0.07600, 0.02840,
        0.35458, 0.90834, 0.13383,
        0.04823, 0.01566, 0.83777);
    const mat3 aces_out = mat3(
        1.60475, -0.10208, -0.00327,
        -0.53108, 1.10813, -0.07276,
        -0.07367, -0.00605, 1.07602);
    vec3 v = aces_in * color;
    vec3 a = v * (v + 0.0245786) - 0.000090537;
    vec3 b = v * (0.983729 * v + 0.4329510) + 0.238081;
    return clamp(aces_out * (a / b), 0.0, 1.0);
}

// Khronos PBR Neutral (Khronos 3D Commerce, 2024).
vec3 pbr_neutral(vec3 color) {
    const float start_compression = 0.8 - 0.04;
    const float desaturation = 0.15;
    float x = min(color.r, min(color.g, color.b));
    float offset = x < 0.08 ? x - 6.25 * x * x : 0.04;
    color -= offset;
    float peak = max(color.r, max(color.g, color.b));
    if (peak < start_compression) {
        return color;
    }
    const float d = 1.0 - start_compression;
    float new_peak = 1.0 - d * d / (peak + d - start_compression);
    color *= new_peak / peak;
    float g = 1.0 - 1.0 / (desaturation * (peak - new_peak) + 1.0);
    return mix(color, new_peak * vec3(1.0), g);
}

vec3 srgb_encode(vec3 linear) {
    vec3 c = clamp(linear, 0.0, 1.0);
    return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}

vec3 tonemap(vec3 hdr, float exposure, uint op) {
    vec3 c = max(hdr, vec3(0.0)) * exposure;
    if (op == TONEMAP_ACES) {
        c = aces_fitted(c);
    } else if (op == TONEMAP_PBR_NEUTRAL) {
        c = pbr_neutral(c);
    }
    return srgb_encode(c);
}
#endif
