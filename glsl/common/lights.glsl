// Punctual lights (and emitters' area samples) and their shadow-map lookups (KHR_lights_punctual conventions).
#ifndef LIGHTS_GLSL
#define LIGHTS_GLSL
#include "shared.glsl"

// Radiance-carrying quantities of one light at a surface point.
struct LightSample {
    vec3 wi;          // unit direction from the surface towards the light
    vec3 irradiance;  // W/m^2 on a surface facing the light (before the cosine)
};

// KHR_lights_punctual spot falloff: a smooth ramp between the outer and inner cone, as a
// function of the cosine `cd` between the axis and the direction to the point (the twin of
// photon::emit::spot_falloff).
float spot_falloff_cos(float cos_inner, float cos_outer, float cd) {
    float scale = 1.0 / max(1e-4, cos_inner - cos_outer);
    float t = clamp((cd - cos_outer) * scale, 0.0, 1.0);
    return t * t;
}

// How a light's intensity falls off with `cd`, the cosine between its axis and the direction
// to the point: the spot cone, max(0, cos) for an emitter's area sample (a one-sided Lambertian
// point), 1 otherwise (the twin of photon::emit::light_falloff).
float light_falloff(uint kind, float cos_inner, float cos_outer, float cd) {
    if (kind == LIGHT_SPOT) {
        return spot_falloff_cos(cos_inner, cos_outer, cd);
    }
    if (kind == LIGHT_AREA_SAMPLE) {
        return max(cd, 0.0);
    }
    return 1.0;
}

LightSample sample_light(GpuLight light, vec3 p) {
    LightSample s;
    if (light.shadow.x == LIGHT_DIRECTIONAL) {
        s.wi = -light.direction.xyz;
        s.irradiance = light.intensity.rgb;
        return s;
    }
    vec3 d = light.position.xyz - p;
    float dist2 = max(dot(d, d), 1e-12);
    s.wi = d * inversesqrt(dist2);
    s.irradiance = light.intensity.rgb / dist2;
    s.irradiance *= light_falloff(light.shadow.x, light.intensity.w, light.direction.w,
                                  dot(light.direction.xyz, -s.wi));
    return s;
}

// Which of a light's shadow views covers `p`: cube lights pick the face by the major axis of
// the light -> point direction, in the face order +X, -X, +Y, -Y, +Z, -Z.
uint shadow_view_index(GpuLight light, vec3 p) {
    if (light.shadow.z < 6u) {
        return light.shadow.y;
    }
    vec3 d = p - light.position.xyz;
    vec3 a = abs(d);
    uint face;
    if (a.x >= a.y && a.x >= a.z) {
        face = d.x >= 0.0 ? 0u : 1u;
    } else if (a.y >= a.z) {
        face = d.y >= 0.0 ? 2u : 3u;
    } else {
        face = d.z >= 0.0 ? 4u : 5u;
    }
    return light.shadow.y + face;
}
#endif
