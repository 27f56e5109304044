#version 460
// Accumulate: the running mean of the frames since the last reset (progressive accumulation,
// src/passes/accumulate.rs). `push.frames` frames are already in `accumulation`; this frame's
// radiance joins them, and the mean goes back into `radiance` for the tonemap and the readback.
#include "shared.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba32f) uniform image2D radiance;
layout(set = 0, binding = 1, rgba32f) uniform image2D accumulation;

layout(push_constant) uniform Push {
    uint width;
    uint height;
    uint frames;
    uint pad;
} push;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (px.x >= int(push.width) || px.y >= int(push.height)) {
        return;
    }
    vec4 current = imageLoad(radiance, px);
    vec4 mean = current;
    if (push.frames > 0u) {
        vec4 previous = imageLoad(accumulation, px);
        // The incremental mean: exact for any count, no sum that grows without bound.
        mean = previous + (current - previous) / float(push.frames + 1u);
    }
    imageStore(accumulation, px, mean);
    imageStore(radiance, px, mean);
}
