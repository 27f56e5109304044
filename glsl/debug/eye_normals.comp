#version 460
// Debug view: the eye G-buffer's shading normals, each axis mapped to a colour channel;
// background black.
#include "debug.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba8) uniform writeonly image2D display;
layout(set = 0, binding = 1) uniform sampler2D g_position;
layout(set = 0, binding = 2) uniform sampler2D g_normal;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(display);
    if (px.x >= size.x || px.y >= size.y) {
        return;
    }
    vec3 c = vec3(0.0);
    if (texelFetch(g_position, px, 0).w != 0.0) {
        c = normal_colour(texelFetch(g_normal, px, 0).xyz);
    }
    imageStore(display, px, vec4(c, 1.0));
}
