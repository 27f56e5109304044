#version 460
// Debug view: photon-volume overdraw, the number of photon volumes that shaded each pixel
// (the indirect image's alpha), on a log scale: 0 black, 1 … `push.max` Turbo.
#include "debug.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba8) uniform writeonly image2D display;
layout(set = 0, binding = 1) uniform sampler2D indirect;

layout(push_constant) uniform Push {
    float max_count;  // the count shown as the top of the scale
    uint pad0;
    uint pad1;
    uint pad2;
} push;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(display);
    if (px.x >= size.x || px.y >= size.y) {
        return;
    }
    float count = texelFetch(indirect, px, 0).a;
    vec3 c = count > 0.0 ? turbo(log2(1.0 + count) / log2(1.0 + push.max_count)) : vec3(0.0);
    imageStore(display, px, vec4(c, 1.0));
}
