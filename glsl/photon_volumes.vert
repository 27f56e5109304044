#version 460
// Photon volumes, vertex stage: one instance per photon; the icosahedron (inscribed sphere of
// radius 1, from the vertex buffer) is scaled to bound the photon's ellipsoidal kernel:
// r_xy in the tangent plane of the surface the photon hit, r_z along its normal. The photon's
// kNN radius is the length of its stored normal (pack_normal).
#include "shared.glsl"
#include "packing.glsl"
#include "kernel.glsl"
#include "bsdf.glsl"

layout(location = 0) in vec3 in_position;

layout(set = 0, binding = 0) uniform Frame { FrameUniforms frame; };
layout(std430, set = 0, binding = 1) readonly buffer Photons { PackedPhoton photons[]; };

layout(push_constant) uniform Push {
    float r_min;
    float r_max;
    uint count;
    uint subsample;
    float footprint;
    float footprint_max;
    float scale;  // the kNN radii's factor (KernelSettings::scale)
    float gather_exponent_max;  // the fragment stages' glossy regularisation
    vec4 offset;  // xyz: photon map origin − eye (the stored positions are origin-relative)
} push;

layout(location = 0) flat out uint v_photon;
layout(location = 1) flat out vec2 v_radius;
layout(location = 2) flat out vec3 v_center;  // the photon's eye-relative position

void main() {
    Photon photon = photon_load(photons[gl_InstanceIndex]);
    float r_knn;
    vec3 n = unpack_normal(photon.normal, r_knn);
    // Eye-relative position: the eye is at the origin of the frame's space.
    vec3 center = photon.position + push.offset.xyz;
    vec2 r = kernel_radius(r_knn, push.r_min, push.r_max, push.scale, push.footprint,
                           push.footprint_max, length(center));
    vec3 t;
    vec3 b;
    frame_from_normal(n, t, b);
    vec3 world = center + (t * in_position.x + b * in_position.y) * r.x
                 + n * (in_position.z * r.y);
    if (!any(greaterThan(photon.power, vec3(0.0)))) {
        // No power: collapse the volume to a point, which rasterises nothing.
        world = center;
    }
    gl_Position = frame.view_proj * vec4(world, 1.0);
    v_photon = uint(gl_InstanceIndex);
    v_radius = r;
    v_center = center;
}
