// A GpuMaterial as the über-BSDF of bsdf.glsl (the twin of photon::bsdf::Bsdf::new).
#ifndef MATERIAL_GLSL
#define MATERIAL_GLSL
#include "shared.glsl"
#include "bsdf.glsl"

// gpu_scene.rs stores a perfect mirror's infinite exponent as 1e30.
Bsdf material_bsdf(GpuMaterial m, vec3 lambertian) {
    float exponent = m.glossy.a >= 1e20 ? uintBitsToFloat(0x7f800000u) : m.glossy.a;
    return bsdf_make(lambertian, m.glossy.rgb, exponent, m.transmission.rgb, m.transmission.a,
                     (m.flags.x & MATERIAL_FRESNEL) != 0u);
}
#endif
