#version 460
// Deferred direct illumination: for every eye G-buffer pixel, the sum over lights of
// BSDF * irradiance * cos * visibility, plus emission. Visibility is a 3x3 grid of hardware
// depth-compare (bilinear PCF) lookups in the light's shadow-atlas layer.
// With WRITE_LAMBERT (--subsample N > 1), also the pixel's Lambertian lobe's BRDF for the
// upsample: rgb = c_L/π (albedo and Fresnel factor at the pixel's own view direction, what
// upsample.comp multiplies the interpolated irradiance by), a = 1 where the BSDF faces the eye
// (0: no indirect light there). The direct pass has the material and albedo at hand;
// reading and making them again per pixel was 40 % of the upsample on lavapipe.
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
// Without WRITE_LAMBERT the pass binds out_radiance here too and never writes it.
layout(set = 0, binding = 10, rgba32f) uniform writeonly image2D out_lambert;

layout(constant_id = SPEC_ID_WRITE_LAMBERT) const bool WRITE_LAMBERT = false;

#include "shadows.glsl"

// One store per image: llvmpipe runs both sides of a branch (the lanes masked).
void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = ivec2(frame.counts.zw);
    if (px.x >= size.x || px.y >= size.y) {
        return;
    }
    vec4 pos = texelFetch(g_position, px, 0);
    vec3 radiance = vec3(0.0);
    vec4 lambert = vec4(0.0);
    if (pos.w != 0.0) {
        vec3 p = pos.xyz;
        vec4 nw = texelFetch(g_normal, px, 0);
        vec3 n = normalize(nw.xyz);
        // The BSDF decides entering/leaving a dielectric from the mesh's own side.
        vec3 n_mesh = n * (nw.w < 0.0 ? -1.0 : 1.0);
        vec3 albedo = texelFetch(g_albedo, px, 0).rgb;
        GpuMaterial m = materials[texelFetch(g_material, px, 0).x];
        Bsdf bsdf = material_bsdf(m, albedo);
        vec3 wo = normalize(-p);
        radiance = material_emission(m, nw.w) + direct_light(bsdf, p, n, n_mesh, wo);
        if (WRITE_LAMBERT) {
            // Oriented by the shading normal alone, as the photon estimate's low-resolution
            // samples are (photon_tiles.comp, photon_volumes_subsampled.frag).
            BsdfOriented o;
            if (bsdf_orient(bsdf, wo, n, n, o)) {
                vec3 c[4];
                bsdf_lobe_reflectances(bsdf, o, c);
                lambert = vec4(c[LOBE_LAMBERTIAN] * (1.0 / PI), 1.0);
            }
        }
    }
    imageStore(out_radiance, px, vec4(radiance, 1.0));
    if (WRITE_LAMBERT) {
        imageStore(out_lambert, px, lambert);
    }
}
