#version 460
// Photon volumes at 1/N resolution (--subsample N > 1), fragment stage. Each low-resolution
// pixel shades the surface the full-resolution eye G-buffer holds at the centre of its N×N
// block, and splits the photon's contribution so that upsample.comp can apply the
// full-resolution BSDF:
//   out_irradiance = Φ · κ            (front side only; times c_L/π at full resolution)
//   out_glossy     = f_glossy · Φ · κ (the non-Lambertian lobes, as radiance at this sample)
//   out_global     = the global photons' share of out_irradiance; a: their Σ κ·r
//   out_weight     = r: the global photons' Σ κ; gba: their share of out_glossy
// (the last two for the support normalisation, src/passes/support.rs; a global photon stays on
// its own surface, as at full resolution).
// There is no depth attachment at this size, so no hardware depth test: the kernel test alone
// discards the surfaces a volume does not contain (see passes/photon_volumes.rs).
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

layout(location = 0) out vec4 out_irradiance;
layout(location = 1) out vec4 out_glossy;
layout(location = 2) out vec4 out_global;
layout(location = 3) out vec4 out_weight;

void main() {
    // The same centre sample as upsample.comp's subsample_centre.
    ivec2 size = ivec2(frame.counts.zw);
    int n = int(push.subsample);
    ivec2 px = min(ivec2(gl_FragCoord.xy) * n + n / 2, size - 1);
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
    vec3 n_s = normalize(texelFetch(g_normal, px, 0).xyz);
    bool global_photon = !(rho_p > CAUSTIC_PATH_DENSITY);
    if (global_photon && abs(dot(normalize(photon.normal), n_s)) < SUPPORT_NORMAL_COS) {
        discard;
    }
    GpuMaterial m = materials[texelFetch(g_material, px, 0).x];
    // The glossy lobe regularised to the kernel's angular resolution (photon/kernel.rs).
    Bsdf bsdf = bsdf_regularized(material_bsdf(m, texelFetch(g_albedo, px, 0).rgb),
                                 push.gather_exponent_max);
    BsdfOriented o;
    if (!bsdf_orient(bsdf, normalize(-pos.xyz), n_s, n_s, o)) {
        discard;
    }
    // Front-side test (the one bsdf_eval applies at full resolution).
    float cos_i = bsdf_reflected_cos(o, wi);
    if (cos_i <= 0.0) {
        discard;
    }
    vec3 c[4];
    bsdf_lobe_reflectances(bsdf, o, c);
    vec3 f;
    float pdf;
    bsdf_eval_and_pdf_oriented(bsdf, o, c, bsdf_weights_of(c), wi, cos_i, f, pdf);
    vec3 flux = photon.power * kappa;
    vec3 glossy = max(f - c[LOBE_LAMBERTIAN] * (1.0 / PI), vec3(0.0));
    out_irradiance = vec4(flux, 1.0);
    out_glossy = vec4(glossy * flux, 0.0);
    out_global = global_photon ? vec4(flux, kappa * v_radius.x) : vec4(0.0);
    out_weight = global_photon ? vec4(kappa, glossy * flux) : vec4(0.0);
}
