// Photon kernel: the twin of src/photon/kernel.rs, formula for formula (see its module docs for
// the normalisation proof). Header only.
#ifndef KERNEL_GLSL
#define KERNEL_GLSL

const float KERNEL_NORMAL_RATIO = 0.5;
const float KERNEL_PI = 3.14159265358979;

// (r_xy, r_z) of a photon with kNN radius r_knn (metres: the length of its packed normal,
// src/photon/density.rs) at eye_distance metres from the eye:
// max(scale * clamp(r_knn, r_min, r_max), footprint floor). r_min, r_max in metres, scale: the kNN radii's factor (> 0),
// footprint: the pixel-footprint floor per metre of distance, footprint_max: the floor's ceiling
// in metres.
vec2 kernel_radius(float r_knn, float r_min, float r_max, float scale, float footprint,
                   float footprint_max, float eye_distance) {
    // <= 0 or NaN: a record without a radius (zero normal) gets the widest kernel.
    // The progressive shrink (scale) applies to the clamped radius, not to the footprint floor
    // (src/photon/kernel.rs).
    float r = (r_knn > 0.0 ? clamp(r_knn, r_min, r_max) : r_max) * scale;
    // A comparison, not max(): a NaN floor (a photon with a broken position) leaves r alone.
    float floor_r = footprint * eye_distance;
    // Camera case (1x1 images, fields of view near 180 degrees): a pixel wider than the room
    // made kernels that spanned its walls; the floor stops at a tenth of the scene.
    if (floor_r > footprint_max) {
        floor_r = footprint_max;
    }
    if (floor_r > r) {
        r = floor_r;
    }
    return vec2(r, r * KERNEL_NORMAL_RATIO);
}

// Whether an estimate of share `share` (SHARE_*: all, fine, coarse) with split `split` draws a
// photon with kNN radius r_knn and path density rho_p at eye_distance metres from the eye: the
// twin of src/photon/kernel.rs's Share::draws. A fine photon is a caustic one whose kernel
// before the footprint floor is narrower than split * eye_distance.
bool kernel_share_draws(uint share, float split, float r_knn, float rho_p, float r_min,
                        float r_max, float scale, float eye_distance) {
    if (share == SHARE_ALL) {
        return true;
    }
    float r = (r_knn > 0.0 ? clamp(r_knn, r_min, r_max) : r_max) * scale;
    bool fine = rho_p > CAUSTIC_PATH_DENSITY && r < split * eye_distance;
    return fine == (share == SHARE_FINE);
}

float kernel_t(vec3 x, vec3 n, float r_xy, float r_z, vec3 s) {
    vec3 d = s - x;
    float dist = length(d);
    if (dist == 0.0) {
        return 0.0;
    }
    float c = min(abs(dot(d, n)) / dist, 1.0);
    return (dist / r_xy) * (1.0 + c * (r_xy - r_z) / r_z);
}

// kappa (1/m^2): integrates to 1 over the tangent disk of radius r_xy.
float kernel_weight(vec3 photon_pos, vec3 photon_normal, float r_xy, float r_z, vec3 s) {
    if (!(r_xy > 0.0 && r_z > 0.0)) {
        return 0.0;
    }
    vec3 d = s - photon_pos;
    if (dot(d, d) >= r_xy * r_xy) {
        return 0.0;
    }
    float t = kernel_t(photon_pos, photon_normal, r_xy, r_z, s);
    return t >= 1.0 ? 0.0 : 3.0 / (KERNEL_PI * r_xy * r_xy) * (1.0 - t);
}

#endif
