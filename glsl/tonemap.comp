#version 460
// Tonemapping: linear HDR radiance -> display-referred sRGB in an 8-bit image.
#include "tonemap.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform sampler2D hdr;
layout(set = 0, binding = 1, rgba8) uniform writeonly image2D ldr;

layout(push_constant) uniform Push {
    float exposure;   // 2^EV
    uint op;          // TONEMAP_*
    uint width;
    uint height;
} push;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (px.x >= int(push.width) || px.y >= int(push.height)) {
        return;
    }
    vec3 c = texelFetch(hdr, px, 0).rgb;
    imageStore(ldr, px, vec4(tonemap(c, push.exposure, push.op), 1.0));
}
