#version 460
// Shadow map: depth only. `draw.model` is the full object -> light clip transform.
#include "shared.glsl"

layout(location = 0) in vec3 in_position;

layout(push_constant) uniform Push { DrawPush draw; };

void main() {
    gl_Position = draw.model * vec4(in_position, 1.0);
}
