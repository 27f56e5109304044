#version 460
// Value check of an HDR image (src/passes/value_check.rs): counts the NaN, ±Inf and negative
// values of its four channels (radiance, indirect radiance and its low-resolution targets,
// whose alpha is a count or 1, are never negative).
#include "value_check.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 1) uniform sampler2D image;

layout(push_constant) uniform Push {
    uint width;
    uint height;
    uint counter;
    uint unused;
} push;

void main() {
    value_check_begin();
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    uint non_finite = 0;
    uint negative = 0;
    uint values = 0;
    if (px.x < int(push.width) && px.y < int(push.height)) {
        vec4 c = texelFetch(image, px, 0);
        for (int i = 0; i < 4; ++i) {
            non_finite += uint(value_non_finite(c[i]));
            negative += uint(value_negative(c[i]));
        }
        values = 4;
    }
    value_check_end(push.counter, non_finite, negative, values);
}
