// Shadowed direct light: shadow-atlas visibility of a light (3x3 bilinear PCF) and the sum over
// lights of BSDF * irradiance * cos * visibility. Include after declaring `frame`
// (FrameUniforms), `lights` (GpuLight[]), `shadow_views` (ShadowView[]) and `shadow_atlas`
// (sampler2DArrayShadow): the direct pass, the environment map and the translucent pass share it.
#ifndef SHADOWS_GLSL
#define SHADOWS_GLSL
#include "lights.glsl"
#include "material.glsl"

// The point looked up in `view` for surface point p (normal n, unit wi towards the light).
// Offset against acne: it goes h = 1.5 texels × sin θ (at least 0.3 texels) off the surface's
// plane, texels measured at the point's distance from the light (perspective) or absolutely
// (ortho): half of h along the normal, half along the ray to the light (h/2 / cos θ). Over a
// planar receiver every PCF tap keeps the margin h either way (the two paths differ by a vector
// in the plane), but a step along the normal also moves the lookup sideways by its length ×
// tan θ, and with it every shadow edge: the whole of h along the normal moved caustic-ring's
// shadows about 4 texels under its 20° sun. The half along the normal is kept for curved
// receivers: along the ray alone, the ring's faceted walls shadowed themselves near their
// terminator (docs/accuracy.md). h is at least view.params.z: an ortho view's depth keeps the
// whole scene's range while its texel may be small (plan/lighting.rs). Along the ray it goes
// at most a quarter of the way to a light at a finite distance (tiny maps at grazing angles
// would pass the light).
vec3 shadow_lookup_point(ShadowView view, GpuLight light, vec3 p, vec3 n, vec3 wi) {
    float dist = view.params.y > 0.5 ? 1.0 : length(light.position.xyz - p);
    float texel = view.params.x * dist;
    float cos_t = clamp(dot(n, wi), 0.0, 1.0);
    float sin_t = sqrt(max(0.0, 1.0 - cos_t * cos_t));
    float h = max(1.5 * texel * max(sin_t, 0.2), view.params.z);
    float along = 0.5 * h / max(cos_t, 0.05);
    if (view.params.y < 0.5) {
        along = min(along, 0.25 * dist);
    }
    return p + n * (0.5 * h) + wi * along;
}

float shadow_visibility(GpuLight light, vec3 p, vec3 n, vec3 wi) {
    uint first = light.shadow.y;
    vec3 q = shadow_lookup_point(shadow_views[first], light, p, n, wi);
    // A directional light's first view is fitted to what the eye sees, the second covers the
    // whole scene (plan/lighting.rs, "Directional lights"): the first where the looked-up
    // point lies 4 texels inside it (the PCF footprint and its bilinear taps stay inside).
    if (light.shadow.x == LIGHT_DIRECTIONAL && light.shadow.z > 1u) {
        vec4 c = shadow_views[first].view_proj * vec4(q, 1.0);
        vec2 uv_q = c.xy / c.w * 0.5 + 0.5;
        float m = 4.0 * frame.params.x;
        if (any(lessThan(uv_q, vec2(m))) || any(greaterThan(uv_q, vec2(1.0 - m)))) {
            first += 1u;
            q = shadow_lookup_point(shadow_views[first], light, p, n, wi);
        }
    }
    // The face is chosen for the point actually looked up (cube faces overlap by a margin
    // that covers the offset and the PCF footprint, see plan/lighting.rs).
    uint vi = light.shadow.x == LIGHT_DIRECTIONAL ? first : shadow_view_index(light, q);
    ShadowView view = shadow_views[vi];
    vec4 clip = view.view_proj * vec4(q, 1.0);
    if (clip.w <= 0.0) {
        return 1.0;
    }
    vec3 ndc = clip.xyz / clip.w;
    vec2 uv = ndc.xy * 0.5 + 0.5;
    // Reversed depth (plan/lighting.rs): beyond the far plane is below 0.
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0))) || ndc.z < 0.0) {
        // Outside the light's view: spot cones and fitted directional frusta cover every
        // point the light reaches, so a point outside is not lit through this view.
        return light.shadow.x == LIGHT_SPOT ? 0.0 : 1.0;
    }
    float step_uv = frame.params.x;
    float sum = 0.0;
    for (int y = -1; y <= 1; ++y) {
        for (int x = -1; x <= 1; ++x) {
            vec2 o = vec2(x, y) * step_uv;
            sum += texture(shadow_atlas, vec4(uv + o, float(vi), ndc.z));
        }
    }
    return sum / 9.0;
}

// Direct light leaving camera-relative point `p` towards `wo`: `n` is the shading normal on
// the viewer's side, `n_mesh` the same normal on the mesh's own side (it decides whether a
// dielectric is entered or left). Delta lobes contribute nothing (a point light is never
// exactly in the mirror direction).
vec3 direct_light(Bsdf bsdf, vec3 p, vec3 n, vec3 n_mesh, vec3 wo) {
    vec3 radiance = vec3(0.0);
    for (uint i = 0u; i < frame.counts.x; ++i) {
        GpuLight light = lights[i];
        LightSample s = sample_light(light, p);
        float cos_i = dot(n, s.wi);
        if (cos_i <= 0.0 || all(equal(s.irradiance, vec3(0.0)))) {
            continue;
        }
        float vis = light.shadow.z > 0u ? shadow_visibility(light, p, n, s.wi) : 1.0;
        if (vis <= 0.0) {
            continue;
        }
        vec3 f = bsdf_eval(bsdf, wo, s.wi, n_mesh, n_mesh);
        radiance += f * s.irradiance * cos_i * vis;
    }
    return radiance;
}
#endif
