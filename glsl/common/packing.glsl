// Photon records and direction packing: the twin of src/photon/types.rs (DESIGN.md §2.1).
//
// Buffer layout (std430): the records are plain f32 arrays on the Rust side, so here they are
// structs of vec4 only: vec4 has size 16 and alignment 16 in std430, a struct of them has the
// alignment 16 and no padding, so `PackedBounceMapPhoton[]` has stride 32 and `PackedPhoton[]`
// stride 48, exactly `size_of::<BounceMapPhoton>()` and `size_of::<Photon>()`. (A struct of
// vec3 members would not do: std430 aligns vec3 to 16 bytes.) Use the load/store functions
// to convert to the unpacked structs.
//
//   PackedBounceMapPhoton  a = (power.rgb, direction.x)   b = (direction.yz, eta, depth)
//   PackedPhoton           a = (power.rgb, direction.x)   b = (direction.yz, position.xy)
//                          c = (position.z, normal.xyz)
//
// `direction` is packed as w * (rho_p + 1) with rho_p clamped to [0, PATH_DENSITY_MAX]; the zero
// vector means "no direction" (absorbed photon). See pack_direction.
//
// A stored photon's `normal`, in the photon map the photon volumes draw, is packed as n * r_i:
// its length is the photon's kNN kernel radius in metres (src/photon/density.rs), clamped to
// [PACKED_RADIUS_MIN, PACKED_RADIUS_MAX] so it is never 0 and its square stays finite. See
// pack_normal; readers of the direction normalise.
#ifndef ISPM_PACKING_GLSL
#define ISPM_PACKING_GLSL

#include "shared_constants.glsl"

struct PackedBounceMapPhoton {
    vec4 a;
    vec4 b;
};

struct PackedPhoton {
    vec4 a;
    vec4 b;
    vec4 c;
};

struct BounceMapPhoton {
    vec3 power;
    vec3 direction; // packed, see pack_direction
    float eta;
    float depth;
};

struct Photon {
    vec3 power;
    vec3 direction; // packed incident direction, see pack_direction
    vec3 position;
    vec3 normal;    // packed with the kernel radius, see pack_normal
};

// w * (rho_p + 1) with w normalised here; zero or non-finite w gives the zero vector.
vec3 pack_direction(vec3 w, float rho_p) {
    float len2 = dot(w, w);
    if (!(len2 > 0.0) || isinf(len2) || isnan(len2)) {
        return vec3(0.0);
    }
    float rho = isnan(rho_p) ? 0.0 : clamp(rho_p, 0.0, PATH_DENSITY_MAX);
    return w * (inversesqrt(len2) * (rho + 1.0));
}

// Returns the unit direction, writes rho_p >= 0; the zero vector gives (0, 0).
vec3 unpack_direction(vec3 v, out float rho_p) {
    float len = length(v);
    if (!(len > 0.0) || isinf(len) || isnan(len)) {
        rho_p = 0.0;
        return vec3(0.0);
    }
    rho_p = max(len - 1.0, 0.0);
    return v / len;
}

// n * r with n normalised here and r clamped to [PACKED_RADIUS_MIN, PACKED_RADIUS_MAX] (NaN: the
// maximum); zero or non-finite n gives the zero vector.
vec3 pack_normal(vec3 n, float radius) {
    float len2 = dot(n, n);
    if (!(len2 > 0.0) || isinf(len2) || isnan(len2)) {
        return vec3(0.0);
    }
    float r = isnan(radius) ? PACKED_RADIUS_MAX
                            : clamp(radius, PACKED_RADIUS_MIN, PACKED_RADIUS_MAX);
    return n * (inversesqrt(len2) * r);
}

// Returns the unit normal, writes the kernel radius; the zero vector gives (0, 0).
vec3 unpack_normal(vec3 v, out float radius) {
    float len = length(v);
    if (!(len > 0.0) || isinf(len) || isnan(len)) {
        radius = 0.0;
        return vec3(0.0);
    }
    radius = len;
    return v / len;
}

BounceMapPhoton bounce_map_photon_load(PackedBounceMapPhoton p) {
    return BounceMapPhoton(p.a.xyz, vec3(p.a.w, p.b.xy), p.b.z, p.b.w);
}

PackedBounceMapPhoton bounce_map_photon_store(BounceMapPhoton p) {
    return PackedBounceMapPhoton(vec4(p.power, p.direction.x),
                                 vec4(p.direction.yz, p.eta, p.depth));
}

Photon photon_load(PackedPhoton p) {
    return Photon(p.a.xyz, vec3(p.a.w, p.b.xy), vec3(p.b.zw, p.c.x), p.c.yzw);
}

PackedPhoton photon_store(Photon p) {
    return PackedPhoton(vec4(p.power, p.direction.x),
                        vec4(p.direction.yz, p.position.xy),
                        vec4(p.position.z, p.normal));
}

// Octahedral encoding of a unit vector into [-1, 1]^2 (Cigolle et al. 2014), for the face
// normal the G-buffers keep in spare channels (eye_gbuffer.frag).
vec2 sign_not_zero(vec2 v) {
    return vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0);
}

vec2 oct_encode(vec3 n) {
    vec2 p = n.xy / (abs(n.x) + abs(n.y) + abs(n.z));
    return n.z >= 0.0 ? p : (1.0 - abs(p.yx)) * sign_not_zero(p);
}

vec3 oct_decode(vec2 p) {
    vec3 n = vec3(p, 1.0 - abs(p.x) - abs(p.y));
    if (n.z < 0.0) {
        n.xy = (1.0 - abs(n.yx)) * sign_not_zero(n.xy);
    }
    return normalize(n);
}

// The face normal a G-buffer texel holds (turned towards the viewer, like its shading normal):
// octahedral, x in albedo.a, y in |normal.w| - 2 (normal.w keeps the mesh side in its sign).
vec3 gbuffer_face_normal(vec4 normal, vec4 albedo) {
    return oct_decode(vec2(albedo.a, abs(normal.w) - 2.0));
}

#endif
