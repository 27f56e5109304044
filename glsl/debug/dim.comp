#version 460
// Debug view, photon positions, step 1: the frame as a dim grey backdrop.
#include "debug.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba8) uniform image2D display;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(display);
    if (px.x >= size.x || px.y >= size.y) {
        return;
    }
    float grey = 0.25 * luminance(imageLoad(display, px).rgb);
    imageStore(display, px, vec4(vec3(grey), 1.0));
}
