#version 460
// Photon volumes, vertex stage: one instance per photon, a billboard (corners (±1, ±1) from the
// vertex buffer) that covers the projection of the sphere of radius r_xy bounding the photon's
// ellipsoidal kernel (r_xy in the tangent plane of the surface the photon hit, r_z ≤ r_xy along
// its normal), perpendicular to the eye ray through the photon at the sphere's far side; the
// whole screen at infinite depth when the eye is inside the sphere (src/passes/photon_volumes.rs
// has the picture and the Rust twin, billboard_half_size). The photon's kNN radius is the length
// of its stored normal (pack_normal).
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
    uint share;   // which photons this estimate draws: SHARE_* (photon::kernel::Share)
    float split;  // the fine photons' kernel radius per metre of eye distance
} push;

layout(location = 0) flat out uint v_photon;
layout(location = 1) flat out vec2 v_radius;
layout(location = 2) flat out vec3 v_center;  // the photon's eye-relative position

void main() {
    Photon photon = photon_load(photons[gl_InstanceIndex]);
    float r_knn;
    unpack_normal(photon.normal, r_knn);
    // Eye-relative position: the eye is at the origin of the frame's space.
    vec3 center = photon.position + push.offset.xyz;
    vec2 r = kernel_radius(r_knn, push.r_min, push.r_max, push.scale, push.footprint,
                           push.footprint_max, length(center));
    float bound = r.x;
    float d = length(center);
    float rho_p;
    unpack_direction(photon.direction, rho_p);
    bool drawn = kernel_share_draws(push.share, push.split, r_knn, rho_p, push.r_min, push.r_max,
                                    push.scale, d);
    if (!any(greaterThan(photon.power, vec3(0.0))) || isnan(d) || !drawn) {
        // No power, a broken position, or a photon another estimate draws: collapse the
        // billboard to a point, which rasterises nothing.
        gl_Position = frame.view_proj * vec4(center, 1.0);
    } else if (!(d > bound * BILLBOARD_INSIDE)) {
        // The eye inside the bounding sphere: the whole screen at infinite depth (reversed-Z).
        gl_Position = vec4(in_position.xy, 0.0, 1.0);
    } else {
        vec3 dir = center / d;
        vec3 t;
        vec3 b;
        frame_from_normal(dir, t, b);
        float far_side = d + bound;
        float half_size = far_side * bound / sqrt(d * d - bound * bound) * BILLBOARD_MARGIN;
        if (push.subsample > 1u) {
            // At 1/N resolution a fragment is made where the billboard covers the
            // low-resolution pixel's centre, but the kernel is evaluated at the full-resolution
            // pixel at the centre of its N×N block (photon_volumes_subsampled.frag): half a
            // full-resolution pixel away, and up to N more where the size is not a multiple of
            // N (the low-resolution grid is ⌈W/N⌉ wide). The billboard grows by two
            // low-resolution pixels at its distance (footprint: one pixel's size per metre), so
            // every pixel whose sample the sphere covers is drawn.
            half_size += 2.0 * push.footprint * far_side;
        }
        vec3 world = dir * far_side + (t * in_position.x + b * in_position.y) * half_size;
        gl_Position = frame.view_proj * vec4(world, 1.0);
    }
    v_photon = uint(gl_InstanceIndex);
    v_radius = r;
    v_center = center;
}
