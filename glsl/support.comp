#version 460
// Support normalisation of the global photons' estimate (src/passes/support.rs): where a
// surface ends (a convex edge) or meets another (a corner), part of every kernel around a
// pixel falls where no photon can land, and the splatted estimate loses that part. The photon
// volumes also summed, for the global photons alone, their contribution G and their kernel
// support W = Σ κ·a (a: the surface area each photon stands for, π r_kNN² / k). W is 1 where
// the kernels lie whole on the surface and the share of them on the surface elsewhere, so
//     total ← total − G + G / max(W, SUPPORT_WEIGHT_MIN)
// puts back what the boundary took. Caustic photons are left alone: their density ends where
// the caustic ends, which is light, not geometry.
#include "shared.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba32f) uniform image2D total0;
layout(set = 0, binding = 1, rgba32f) uniform image2D global0;  // alpha: W
layout(set = 0, binding = 2, rgba32f) uniform image2D total1;
layout(set = 0, binding = 3, rgba32f) uniform image2D global1;

layout(push_constant) uniform Push {
    uint width;
    uint height;
    uint pairs;  // 1: (total0, global0); 2: and (total1, global1), normalised by the same W
    uint pad;
} push;

void normalise(ivec2 px, vec4 total, vec3 global, float w, bool second) {
    vec3 rgb = total.rgb - global + global / max(w, SUPPORT_WEIGHT_MIN);
    if (second) {
        imageStore(total1, px, vec4(rgb, total.a));
    } else {
        imageStore(total0, px, vec4(rgb, total.a));
    }
}

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (px.x >= int(push.width) || px.y >= int(push.height)) {
        return;
    }
    vec4 g0 = imageLoad(global0, px);
    float w = g0.a;
    if (!(w > 0.0)) {
        return;  // no global photon here: nothing to normalise
    }
    normalise(px, imageLoad(total0, px), g0.rgb, w, false);
    if (push.pairs > 1u) {
        normalise(px, imageLoad(total1, px), imageLoad(global1, px).rgb, w, true);
    }
}
