#version 460
// Support normalisation of the global photons' estimate (src/passes/support.rs): the share
// f(s) of the cone kernel around pixel s that lies on s's own surface, measured in screen
// space from the eye G-buffer, and total ← total − G + G / max(f, SUPPORT_FRACTION_MIN).
// Caustic photons (not in G) are left alone. (G / f, r) is written back into global_share
// (the denoiser's input: the normalised share and the mean kernel radius). At --subsample N > 1 (SUBSAMPLED) the targets
// are the low-resolution ones: each pixel stands for the G-buffer pixel at the centre of its
// N×N block (as in photon_volumes_subsampled.frag), the irradiance and glossy estimates are
// both normalised, and the global photons' glossy share is global_weight's gba.
#include "shared.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform Frame { FrameUniforms frame; };
layout(set = 0, binding = 1) uniform sampler2D g_position;
layout(set = 0, binding = 2) uniform sampler2D g_normal;
layout(set = 0, binding = 3, rgba32f) uniform image2D total;
layout(set = 0, binding = 4, rgba32f) uniform image2D global_share;  // a: Σ κ·r; ← (G / f, r)
layout(set = 0, binding = 5, rgba32f) uniform image2D global_weight;  // r: Σ κ; g ← f
// At --subsample N > 1: the low-resolution glossy estimate (otherwise `total` again, unused).
layout(set = 0, binding = 6, rgba32f) uniform image2D total_glossy;

layout(constant_id = SPEC_ID_SUBSAMPLED) const bool SUBSAMPLED = false;

layout(push_constant) uniform Push {
    uint width;      // the targets'
    uint height;
    uint g_width;    // the eye G-buffer's
    uint g_height;
    uint subsample;
    uint pad0;
    uint pad1;
    uint pad2;
} push;

const int RINGS = 4;
const int ANGLES = 4;
// Tangent-plane distance, relative to the kernel radius, within which a G-buffer point lies
// on the shaded surface.
const float PLANE_TOLERANCE = 0.2;

// 1 where the kernel's sample point y (eye-relative) lies on the surface of s (normal n), or
// where the image cannot tell (off screen, hidden behind an unrelated occluder); 0 where the
// surface has ended there (a convex edge: the G-buffer sees past y; a crease: y lies just
// inside the other wall).
float present(vec3 s, vec3 n, float r, vec3 y) {
    vec4 clip = frame.view_proj * vec4(y, 1.0);
    if (!(clip.w > 0.0)) {
        return 1.0;
    }
    vec2 uv = clip.xy / clip.w * 0.5 + 0.5;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThanEqual(uv, vec2(1.0)))) {
        return 1.0;
    }
    ivec2 q = ivec2(uv * vec2(push.g_width, push.g_height));
    vec4 p = texelFetch(g_position, q, 0);
    if (p.w == 0.0) {
        return 0.0;  // nothing behind the edge
    }
    vec3 np = normalize(texelFetch(g_normal, q, 0).xyz);
    float tolerance = PLANE_TOLERANCE * r;
    if (abs(dot(p.xyz - s, n)) < tolerance && dot(np, n) > SUPPORT_NORMAL_COS) {
        return 1.0;
    }
    if (length(p.xyz) < length(y) - tolerance) {
        // y is hidden: inside the solid across a crease when it lies within a kernel radius
        // of the hiding surface's plane, else behind an occluder (unknown: present).
        return abs(dot(y - p.xyz, np)) < r ? 0.0 : 1.0;
    }
    return 0.0;  // the G-buffer sees past y: a convex edge
}

void main() {
    ivec2 id = ivec2(gl_GlobalInvocationID.xy);
    if (id.x >= int(push.width) || id.y >= int(push.height)) {
        return;
    }
    // The G-buffer pixel this target pixel shades.
    int block = int(push.subsample);
    ivec2 px = SUBSAMPLED ? min(id * block + block / 2, ivec2(push.g_width, push.g_height) - 1)
                          : id;
    vec4 weight = imageLoad(global_weight, id);
    float w = weight.r;
    if (!(w > 0.0)) {
        return;  // no global photon here: nothing to normalise
    }
    vec4 g = imageLoad(global_share, id);
    vec4 pos = texelFetch(g_position, px, 0);
    if (pos.w == 0.0) {
        return;
    }
    float r = g.a / w;  // the κ-weighted mean kernel radius of the photons that reached s
    if (!(r > 0.0)) {
        return;
    }
    vec3 s = pos.xyz;
    vec3 n = normalize(texelFetch(g_normal, px, 0).xyz);
    vec3 t = normalize(abs(n.x) > 0.5 ? cross(n, vec3(0.0, 1.0, 0.0)) : cross(n, vec3(1.0, 0.0, 0.0)));
    vec3 b = cross(n, t);
    // A rotation per pixel (interleaved gradient noise) so that the stratified pattern does
    // not line up along straight edges.
    float rotation = 2.0 * PI * fract(52.9829189 * fract(0.06711056 * float(px.x)
                                                         + 0.00583715 * float(px.y)));
    float on = 0.0;
    float all_ = 0.0;
    for (int i = 0; i < RINGS; i++) {
        float rho = (float(i) + 0.5) / float(RINGS);
        float weight = (1.0 - rho) * rho;  // the cone times the ring's circumference
        for (int j = 0; j < ANGLES; j++) {
            float a = rotation + 2.0 * PI * (float(j) + 0.5 * float(i & 1)) / float(ANGLES);
            vec3 y = s + (cos(a) * t + sin(a) * b) * (rho * r);
            on += weight * present(s, n, r, y);
            all_ += weight;
        }
    }
    float f = on / all_;
    float scale = 1.0 / max(f, SUPPORT_FRACTION_MIN) - 1.0;
    vec4 old = imageLoad(total, id);
    imageStore(total, id, vec4(old.rgb + g.rgb * scale, old.a));
    // The normalised global share and its mean kernel radius, for the denoiser
    // (passes/denoise.rs), which filters it alone, up to the scale of its kernels.
    imageStore(global_share, id, vec4(g.rgb * (1.0 + scale), r));
    if (SUBSAMPLED) {
        vec4 glossy = imageLoad(total_glossy, id);
        imageStore(total_glossy, id, vec4(glossy.rgb + weight.gba * scale, glossy.a));
    } else {
        // The fraction, for the estimator-equivalence test (PhotonFrame::read_support_fraction).
        imageStore(global_weight, id, vec4(w, f, weight.ba));
    }
}
