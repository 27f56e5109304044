#version 460
// Debug view, photon positions, step 2: every stored photon as one pixel where the eye sees it
// (hidden behind the eye G-buffer's surfaces: not drawn), coloured by its power on a log scale
// (Turbo, 4 decades below the brightest photon).
#include "shared.glsl"
#include "packing.glsl"
#include "debug.glsl"

layout(local_size_x = 64) in;

layout(set = 0, binding = 0, rgba8) uniform writeonly image2D display;
layout(set = 0, binding = 1) uniform Frame { FrameUniforms frame; };
layout(std430, set = 0, binding = 2) readonly buffer Photons { PackedPhoton photons[]; };
layout(set = 0, binding = 3) uniform sampler2D g_position;

layout(push_constant) uniform Push {
    vec4 offset;     // xyz: photon map origin − eye (the stored positions are origin-relative)
    uint count;
    float inv_peak;  // 1 / the brightest photon's luminance
    uint pad0;
    uint pad1;
} push;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= push.count) {
        return;
    }
    Photon p = photon_load(photons[i]);
    vec3 eye_relative = p.position + push.offset.xyz;
    vec4 clip = frame.view_proj * vec4(eye_relative, 1.0);
    if (clip.w <= 0.0) {
        return;
    }
    vec2 ndc = clip.xy / clip.w;
    ivec2 size = imageSize(display);
    ivec2 px = ivec2(floor((ndc * 0.5 + 0.5) * vec2(size)));
    if (any(lessThan(px, ivec2(0))) || any(greaterThanEqual(px, size))) {
        return;
    }
    vec4 surface = texelFetch(g_position, px, 0);
    // Behind the visible surface (by more than 2 %, the photons lie on surfaces themselves).
    if (surface.w != 0.0 && length(eye_relative) > 1.02 * length(surface.xyz)) {
        return;
    }
    float lum = luminance(p.power);
    imageStore(display, px, vec4(turbo(log_scale(lum, push.inv_peak, 4.0)), 1.0));
}
