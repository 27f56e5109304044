// The non-delta part of the über-BSDF, for direct lighting: Lambertian plus the normalised
// Blinn-Phong glossy lobe. Delta lobes (mirror, refraction) receive no direct light from
// punctual lights.
#ifndef DIRECT_BSDF_GLSL
#define DIRECT_BSDF_GLSL
#include "shared.glsl"

vec3 direct_bsdf_eval(GpuMaterial m, vec3 lambertian, vec3 wo, vec3 wi, vec3 n) {
    vec3 f = lambertian / PI;
    float exponent = m.glossy.a;
    if (exponent < 1e20 && any(greaterThan(m.glossy.rgb, vec3(0.0)))) {
        vec3 h = normalize(wo + wi);
        float c = max(dot(n, h), 0.0);
        f += m.glossy.rgb * ((exponent + 2.0) / (2.0 * PI)) * pow(c, exponent);
    }
    return f;
}
#endif
