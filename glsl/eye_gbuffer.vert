#version 460
// Eye G-buffer, vertex stage: object -> camera-relative world -> clip.
#include "shared.glsl"

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;

layout(set = 0, binding = 0) uniform Frame { FrameUniforms frame; };
layout(push_constant) uniform Push { DrawPush draw; };

layout(location = 0) out vec3 v_position;
layout(location = 1) out vec3 v_normal;
layout(location = 2) out vec2 v_uv;

void main() {
    vec4 world = draw.model * vec4(in_position, 1.0);
    mat3 normal_matrix = mat3(draw.normal0.xyz, draw.normal1.xyz, draw.normal2.xyz);
    v_position = world.xyz;
    v_normal = normal_matrix * in_normal;
    v_uv = in_uv;
    gl_Position = frame.view_proj * world;
}
