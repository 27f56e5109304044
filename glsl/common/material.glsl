// A GpuMaterial as the über-BSDF of bsdf.glsl (the twin of photon::bsdf::Bsdf::new).
#ifndef MATERIAL_GLSL
#define MATERIAL_GLSL
#include "shared.glsl"
#include "bsdf.glsl"

// gpu/scene.rs stores a perfect mirror's infinite exponent as 1e30.
Bsdf material_bsdf(GpuMaterial m, vec3 lambertian) {
    float exponent = m.glossy.a >= 1e20 ? uintBitsToFloat(0x7f800000u) : m.glossy.a;
    return bsdf_make(lambertian, m.glossy.rgb, exponent, m.transmission.rgb, m.transmission.a,
                     (m.flags.x & MATERIAL_FRESNEL) != 0u);
}

// The radiance a surface emits towards a viewer on its `side` (+1: the side its normals face,
// -1: the other): emitters emit from their front only, unless double-sided (scene/emitters.rs;
// the path tracer's twin is photon::trace::emitted).
vec3 material_emission(GpuMaterial m, float side) {
    bool emits = side >= 0.0 || (m.flags.x & MATERIAL_DOUBLE_SIDED) != 0u;
    return emits ? m.emission.rgb : vec3(0.0);
}
#endif
