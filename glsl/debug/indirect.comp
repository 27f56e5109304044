#version 460
// Debug view: indirect light only, the photon volumes' estimate (upsampled at --subsample > 1)
// before it is added to the direct light, with the frame's exposure and display transform.
#include "tonemap.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba8) uniform writeonly image2D display;
layout(set = 0, binding = 1) uniform sampler2D indirect;

layout(push_constant) uniform Push {
    float exposure;  // 2^EV
    uint op;         // TONEMAP_*
    uint pad0;
    uint pad1;
} push;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(display);
    if (px.x >= size.x || px.y >= size.y) {
        return;
    }
    vec3 c = texelFetch(indirect, px, 0).rgb;
    imageStore(display, px, vec4(tonemap(c, push.exposure, push.op), 1.0));
}
