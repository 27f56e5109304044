#version 460
// Photon volumes, fragment stage: the photon's contribution to the surface point the eye
// G-buffer holds at this pixel, ΔL = f(s, ωi, ωo) · Φ · κ (paper eq. 1, with the cosine as a
// front-side test), added into the indirect radiance buffer by additive blending. Alpha counts
// the volumes that touched the pixel (the overdraw view). A global photon (not a caustic one)
// reaches only surfaces facing its own way, and also adds its contribution and κ·r to the
// global target and κ to the weight target, for the support normalisation
// (src/passes/support.rs).
#include "shared.glsl"
#include "packing.glsl"
#include "kernel.glsl"
#include "material.glsl"

layout(set = 0, binding = 0) uniform Frame { FrameUniforms frame; };
layout(std430, set = 0, binding = 1) readonly buffer Photons { PackedPhoton photons[]; };
layout(std430, set = 0, binding = 2) readonly buffer Materials { GpuMaterial materials[]; };
layout(set = 0, binding = 3) uniform sampler2D g_position;
layout(set = 0, binding = 4) uniform sampler2D g_normal;
layout(set = 0, binding = 5) uniform sampler2D g_albedo;
layout(set = 0, binding = 6) uniform usampler2D g_material;

layout(push_constant) uniform Push {
    float r_min;
    float r_max;
    uint count;
    uint subsample;
    float footprint;
    float footprint_max;
    float scale;
    float gather_exponent_max;  // the glossy lobes' regularisation (photon/kernel.rs)
} push;

layout(location = 0) flat in uint v_photon;
layout(location = 1) flat in vec2 v_radius;
layout(location = 2) flat in vec3 v_center;  // the photon's eye-relative position

layout(location = 0) out vec4 out_indirect;
layout(location = 1) out vec4 out_global;  // rgb: the global photons' share; a: Σ κ·r
layout(location = 2) out vec4 out_weight;  // r: Σ κ of the global photons

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec4 pos = texelFetch(g_position, px, 0);
    if (pos.w == 0.0) {
        discard;
    }
    Photon photon = photon_load(photons[v_photon]);
    float kappa = kernel_weight(v_center, normalize(photon.normal), v_radius.x, v_radius.y,
                                pos.xyz);
    if (!(kappa > 0.0)) {
        discard;
    }
    float rho_p;
    vec3 wi = unpack_direction(photon.direction, rho_p);
    vec3 n = normalize(texelFetch(g_normal, px, 0).xyz);
    bool global_photon = !(rho_p > CAUSTIC_PATH_DENSITY);
    // A global photon stays on its own surface: the other wall of a crease is not its to light
    // (the support normalisation counts the kernel on the shaded surface alone).
    if (global_photon && abs(dot(normalize(photon.normal), n)) < SUPPORT_NORMAL_COS) {
        discard;
    }
    // Front-side test: the photon arrived on the side of the surface the viewer sees.
    if (dot(wi, n) <= 0.0) {
        discard;
    }
    vec3 wo = normalize(-pos.xyz);
    GpuMaterial m = materials[texelFetch(g_material, px, 0).x];
    // The glossy lobe regularised to the kernel's angular resolution (photon/kernel.rs).
    Bsdf bsdf = bsdf_regularized(material_bsdf(m, texelFetch(g_albedo, px, 0).rgb),
                                 push.gather_exponent_max);
    vec3 f = bsdf_eval(bsdf, wo, wi, n, n);
    vec3 c = f * photon.power * kappa;
    out_indirect = vec4(c, 1.0);
    out_global = global_photon ? vec4(c, kappa * v_radius.x) : vec4(0.0);
    out_weight = global_photon ? vec4(kappa, 0.0, 0.0, 0.0) : vec4(0.0);
}
