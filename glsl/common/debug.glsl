// False colours of the debug views (glsl/debug/*.comp, src/passes/debug_view.rs).
#ifndef DEBUG_GLSL
#define DEBUG_GLSL

// Google's Turbo colour map (Mikhailov 2019), polynomial fit: 0 dark blue … 1 dark red.
vec3 turbo(float t) {
    const vec4 kr4 = vec4(0.13572138, 4.61539260, -42.66032258, 132.13108234);
    const vec4 kg4 = vec4(0.09140261, 2.19418839, 4.84296658, -14.18503333);
    const vec4 kb4 = vec4(0.10667330, 12.64194608, -60.58204836, 110.36276771);
    const vec2 kr2 = vec2(-152.94239396, 59.28637943);
    const vec2 kg2 = vec2(4.27729857, 2.82956604);
    const vec2 kb2 = vec2(-89.90310912, 27.34824973);
    t = clamp(t, 0.0, 1.0);
    vec4 v4 = vec4(1.0, t, t * t, t * t * t);
    vec2 v2 = v4.zw * v4.z;
    return clamp(vec3(dot(v4, kr4) + dot(v2, kr2), dot(v4, kg4) + dot(v2, kg2),
                      dot(v4, kb4) + dot(v2, kb2)), 0.0, 1.0);
}

// A unit normal as a colour: each axis from -1 … 1 to 0 … 1.
vec3 normal_colour(vec3 n) {
    return clamp(normalize(n) * 0.5 + 0.5, 0.0, 1.0);
}

float luminance(vec3 c) {
    return dot(c, vec3(0.2126, 0.7152, 0.0722));
}

// A power on a log scale over `decades` decades below `peak`'s reciprocal `inv_peak`: 1 at
// the peak, 0 `decades` decades below it.
float log_scale(float value, float inv_peak, float decades) {
    return clamp(1.0 + log(max(value * inv_peak, 1e-30)) / (decades * log(10.0)), 0.0, 1.0);
}

#endif
