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

// The mean of nine bilinear depth-compare taps one texel apart around `uv` in layer `layer`
// (3x3 bilinear PCF), from the 4x4 texels they cover: four gathers of 2x2 compares instead of
// nine filtered lookups of 2x2 each. Texel i of a row (i = 0..3, from the one left of the
// centre tap's footprint) is in the taps with total weight 1 - f, 1, 1, f, f the bilinear
// fraction at `uv`; the product of a row's and a column's weights is the texel's share of the
// nine taps, so the sum is the taps' sum (up to the filter's sub-texel rounding).
float pcf3x3(vec2 uv, float layer, float depth) {
    float size = 1.0 / frame.params.x; // the atlas layer's side in texels
    vec2 t = uv * size - 0.5;
    vec2 base = floor(t);
    vec2 f = t - base;
    vec4 wx = vec4(1.0 - f.x, 1.0, 1.0, f.x);
    vec4 wy = vec4(1.0 - f.y, 1.0, 1.0, f.y);
    float sum = 0.0;
    for (int by = 0; by < 2; ++by) {
        for (int bx = 0; bx < 2; ++bx) {
            // The 2x2 texels base + (2bx - 1, 2by - 1) + {0, 1}²: gathered at their shared
            // corner. Components: x (i0, j1), y (i1, j1), z (i1, j0), w (i0, j0).
            vec2 corner = (base + vec2(2 * bx, 2 * by)) / size;
            vec4 c = textureGather(shadow_atlas, vec3(corner, layer), depth);
            float x0 = wx[2 * bx], x1 = wx[2 * bx + 1];
            float y0 = wy[2 * by], y1 = wy[2 * by + 1];
            sum += c.w * x0 * y0 + c.z * x1 * y0 + c.x * x0 * y1 + c.y * x1 * y1;
        }
    }
    return sum / 9.0;
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
    return pcf3x3(uv, float(vi), ndc.z);
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
