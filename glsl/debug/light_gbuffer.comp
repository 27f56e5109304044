#version 460
// Debug view: the first light view's G-buffer (layer 0 of the light G-buffer), its normals as
// colours, stretched over the display; texels that saw nothing black.
#include "debug.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba8) uniform writeonly image2D display;
layout(set = 0, binding = 1) uniform sampler2DArray l_position;
layout(set = 0, binding = 2) uniform sampler2DArray l_normal;

layout(push_constant) uniform Push {
    uvec2 extent;  // the view's texels (within the layer)
    uint layer;
    uint pad;
} push;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(display);
    if (px.x >= size.x || px.y >= size.y) {
        return;
    }
    ivec2 t = min(ivec2((vec2(px) + 0.5) * vec2(push.extent) / vec2(size)),
                  ivec2(push.extent) - 1);
    ivec3 texel = ivec3(t, int(push.layer));
    vec3 c = vec3(0.0);
    if (texelFetch(l_position, texel, 0).w != 0.0) {
        c = normal_colour(texelFetch(l_normal, texel, 0).xyz);
    }
    imageStore(display, px, vec4(c, 1.0));
}
