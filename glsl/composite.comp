#version 460
// Composite: radiance (direct, from the direct pass) += indirect (photon volumes).
#include "shared.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform sampler2D indirect;
layout(set = 0, binding = 1, rgba32f) uniform image2D radiance;

layout(push_constant) uniform Push {
    uint width;
    uint height;
} push;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (px.x >= int(push.width) || px.y >= int(push.height)) {
        return;
    }
    vec4 direct = imageLoad(radiance, px);
    vec3 sum = direct.rgb + texelFetch(indirect, px, 0).rgb;
    imageStore(radiance, px, vec4(sum, 1.0));
}
