// The über-BSDF: the twin of src/photon/bsdf.rs and src/photon/sampling.rs, formula for
// formula, with the same function names (prefixed `bsdf_` where Rust has a method). The module
// docs of bsdf.rs state the conventions and formulas; in short:
//   wo, wi point away from the surface; normals are flipped to wo's side of the GEOMETRIC
//   normal, which also decides eta (front: ior, back: 1/ior).
//   Lambertian c_L/pi; glossy c_S D(h) / (4 (wi.h) max(cos_o, cos_i) E(s, cos_o)),
//   D = (s+1)/(2pi) cos^s, E the shape's directional albedo (glossy_albedo.glsl);
//   mirror (exponent = +inf, test with isinf) and refraction are delta lobes; TIR reflects.
//   Fresnel (optional): S = (F - F0)/(1 - F0); c_S = rhoS + (1 - rhoS) S, c_L, c_T *= 1 - S.
// Inputs are assumed sanitised (bsdf_make does what Bsdf::new does); GPUs may not honour NaN
// semantics, so do not rely on the isnan checks for garbage input.
// Variants: the specialisation constants BSDF_GLOSSY_LOBE and BSDF_DELTA_LOBES (ids in
// shared_constants.glsl, values from photon::bsdf::BsdfVariant, both true unless a pipeline
// sets them) compile the finite glossy lobe and the delta lobes out: a lobe that is off has
// zero reflectance and its sampling and evaluation code is dead. For a material without that
// lobe the result is the same either way (docs/effects.md).
#ifndef ISPM_BSDF_GLSL
#define ISPM_BSDF_GLSL

#include "shared_constants.glsl"
#include "glossy_albedo.glsl"

layout(constant_id = SPEC_ID_GLOSSY_LOBE) const bool BSDF_GLOSSY_LOBE = true;
layout(constant_id = SPEC_ID_DELTA_LOBES) const bool BSDF_DELTA_LOBES = true;

const uint LOBE_LAMBERTIAN = 0u;
const uint LOBE_GLOSSY = 1u;
const uint LOBE_MIRROR = 2u;
const uint LOBE_REFRACTION = 3u;

struct Bsdf {
    vec3 lambertian;
    vec3 glossy;
    float exponent; // +inf: perfect mirror
    float fresnel_exponent; // the material's own exponent: the Fresnel share (bsdf_regularized)
    vec3 transmission;
    float ior;
    bool fresnel;
};

struct BsdfSample {
    vec3 wi;
    vec3 weight;
    float pdf;
    uint lobe;
    float eta;
    float path_density_factor;
};

struct BsdfOriented {
    vec3 wo;
    vec3 t;
    vec3 b;
    vec3 n;
    vec3 ng;
    float cos_o;
    float eta;
};

// ---- sampling.rs ----------------------------------------------------------------------------

// Duff et al. 2017; sign test n.z >= 0 as in Frame::from_normal.
void frame_from_normal(vec3 n, out vec3 t, out vec3 b) {
    float sign_z = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (sign_z + n.z);
    float bb = n.x * n.y * a;
    t = vec3(1.0 + sign_z * n.x * n.x * a, sign_z * bb, -sign_z * n.x);
    b = vec3(bb, sign_z + n.y * n.y * a, -n.y);
}

vec3 frame_to_world(BsdfOriented o, vec3 v) {
    return o.t * v.x + o.b * v.y + o.n * v.z;
}

vec2 concentric_disk(vec2 u) {
    vec2 o = 2.0 * u - 1.0;
    if (o.x == 0.0 && o.y == 0.0) {
        return vec2(0.0);
    }
    float r;
    float theta;
    if (abs(o.x) > abs(o.y)) {
        r = o.x;
        theta = (PI / 4.0) * (o.y / o.x);
    } else {
        r = o.y;
        theta = PI / 2.0 - (PI / 4.0) * (o.x / o.y);
    }
    return r * vec2(cos(theta), sin(theta));
}

vec3 cosine_hemisphere(vec2 u) {
    vec2 d = concentric_disk(u);
    return vec3(d, sqrt(max(1.0 - dot(d, d), 0.0)));
}

float cosine_hemisphere_pdf(float cos_theta) {
    return max(cos_theta, 0.0) / PI;
}

vec3 blinn_phong_half_vector(vec2 u, float exponent) {
    float cos_theta = min(pow(u.x, 1.0 / (exponent + 1.0)), 1.0);
    float sin_theta = sqrt(max(1.0 - cos_theta * cos_theta, 0.0));
    float phi = 2.0 * PI * u.y;
    return vec3(sin_theta * cos(phi), sin_theta * sin(phi), cos_theta);
}

float blinn_phong_half_vector_pdf(float cos_theta_h, float exponent) {
    if (cos_theta_h <= 0.0) {
        return 0.0;
    }
    return (exponent + 1.0) / (2.0 * PI) * pow(min(cos_theta_h, 1.0), exponent);
}

vec3 uniform_sphere(vec2 u) {
    float z = 1.0 - 2.0 * u.x;
    float r = sqrt(max(1.0 - z * z, 0.0));
    float phi = 2.0 * PI * u.y;
    return vec3(r * cos(phi), r * sin(phi), z);
}

// ---- bsdf.rs --------------------------------------------------------------------------------

float bsdf_mean(vec3 v) {
    return (v.x + v.y + v.z) * (1.0 / 3.0);
}

bool bsdf_unit(vec3 v, out vec3 u) {
    float l2 = dot(v, v);
    u = vec3(0.0);
    if (!(l2 >= BSDF_MIN_LENGTH_SQUARED) || isinf(l2)) {
        return false;
    }
    u = v * inversesqrt(l2);
    return true;
}

vec3 bsdf_sanitize_reflectance(vec3 v) {
    return mix(clamp(v, 0.0, 1.0), vec3(0.0), isnan(v));
}

// The twin of Bsdf::new: clamps reflectances to [0, 1], scales their sum to <= 1 per channel,
// exponent in [0, GLOSSY_EXPONENT_MAX] or +inf, ior finite and > 0 (else 1).
Bsdf bsdf_make(vec3 lambertian, vec3 glossy, float exponent, vec3 transmission, float ior,
               bool fresnel) {
    vec3 l = bsdf_sanitize_reflectance(lambertian);
    vec3 g = bsdf_sanitize_reflectance(glossy);
    vec3 t = bsdf_sanitize_reflectance(transmission);
    vec3 scale = vec3(1.0) / max(l + g + t, vec3(1.0));
    float e = isnan(exponent) ? 0.0
            : ((isinf(exponent) && exponent > 0.0) ? exponent
                                                   : clamp(exponent, 0.0, GLOSSY_EXPONENT_MAX));
    float eta = (!isinf(ior) && ior > 0.0) ? ior : 1.0;
    return Bsdf(l * scale, g * scale, e, e, t * scale, eta, fresnel);
}

// The BSDF with its glossy lobe's shape widened to an exponent of at most max_exponent (+inf,
// mirrors and glass, stays a delta lobe), its split between the lobes (the Fresnel share, from
// fresnel_exponent) kept: the lobe the photon volumes evaluate (src/photon/kernel.rs, "Glossy
// lobes in the estimate"; Rust twin Bsdf::regularized).
Bsdf bsdf_regularized(Bsdf bsdf, float max_exponent) {
    if (!isinf(bsdf.exponent) && bsdf.exponent > max_exponent) {
        bsdf.exponent = max(max_exponent, 0.0);
    }
    return bsdf;
}

float fresnel_dielectric(float cos_i, float eta) {
    if (abs(eta - 1.0) < 1e-6) {
        return 0.0;
    }
    cos_i = clamp(cos_i, 0.0, 1.0);
    float sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.0) {
        return 1.0;
    }
    float cos_t = sqrt(1.0 - sin2_t);
    float r_parallel = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    float r_perpendicular = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    return clamp(0.5 * (r_parallel * r_parallel + r_perpendicular * r_perpendicular), 0.0, 1.0);
}

float fresnel_ramp(float cos_i, float eta) {
    float r = (eta - 1.0) / (eta + 1.0);
    float f0 = r * r;
    return clamp((fresnel_dielectric(cos_i, eta) - f0) / (1.0 - f0), 0.0, 1.0);
}

// The share of the Fresnel ramp a lobe of exponent sigma keeps, 1 - r (r: the perceptual
// roughness of sigma); twin of fresnel_ramp_share in src/photon/bsdf.rs.
float fresnel_ramp_share(float exponent) {
    if (isnan(exponent) || exponent <= 0.0) {
        return 0.0;
    }
    return 1.0 - pow(2.0 / (exponent + 2.0), 0.25);
}

float path_density_factor(uint lobe, vec3 reflectance) {
    float rho = bsdf_mean(reflectance);
    if (lobe == LOBE_LAMBERTIAN) {
        return rho / PATH_DENSITY_LAMBERTIAN_DIVISOR;
    }
    if (lobe == LOBE_GLOSSY) {
        return rho / PATH_DENSITY_GLOSSY_DIVISOR;
    }
    return rho;
}

vec3 bsdf_reflect(vec3 wo, vec3 n) {
    return 2.0 * dot(wo, n) * n - wo;
}

bool bsdf_is_mirror(Bsdf bsdf) {
    return isinf(bsdf.exponent);
}

bool bsdf_orient(Bsdf bsdf, vec3 wo, vec3 n_s, vec3 n_g, out BsdfOriented o) {
    vec3 w;
    vec3 ns;
    vec3 ng;
    o = BsdfOriented(vec3(0.0), vec3(0.0), vec3(0.0), vec3(0.0), vec3(0.0), 0.0, 1.0);
    if (!bsdf_unit(wo, w) || !bsdf_unit(n_s, ns) || !bsdf_unit(n_g, ng)) {
        return false;
    }
    float cos_g = dot(w, ng);
    if (cos_g == 0.0 || isinf(cos_g) || isnan(cos_g)) {
        return false;
    }
    bool entering = cos_g > 0.0;
    if (!entering) {
        ns = -ns;
        ng = -ng;
    }
    float cos_o = dot(w, ns);
    if (!(cos_o >= BSDF_MIN_COS)) {
        return false;
    }
    o.wo = w;
    o.n = ns;
    frame_from_normal(ns, o.t, o.b);
    o.ng = ng;
    o.cos_o = min(cos_o, 1.0);
    o.eta = entering ? bsdf.ior : 1.0 / bsdf.ior;
    return true;
}

void bsdf_lobe_reflectances(Bsdf bsdf, BsdfOriented o, out vec3 c[4]) {
    float s = bsdf.fresnel ? fresnel_ramp(o.cos_o, o.eta) * fresnel_ramp_share(bsdf.fresnel_exponent) : 0.0;
    vec3 specular = bsdf.glossy + (vec3(1.0) - bsdf.glossy) * s;
    bool mirror = bsdf_is_mirror(bsdf);
    c[LOBE_LAMBERTIAN] = bsdf.lambertian * (1.0 - s);
    c[LOBE_GLOSSY] = (BSDF_GLOSSY_LOBE && !mirror) ? specular : vec3(0.0);
    c[LOBE_MIRROR] = (BSDF_DELTA_LOBES && mirror) ? specular : vec3(0.0);
    c[LOBE_REFRACTION] = BSDF_DELTA_LOBES ? bsdf.transmission * (1.0 - s) : vec3(0.0);
}

vec4 bsdf_weights_of(vec3 c[4]) {
    return vec4(bsdf_mean(c[0]), bsdf_mean(c[1]), bsdf_mean(c[2]), bsdf_mean(c[3]));
}

// Mean reflectance of each lobe, indexed by LOBE_*; the sum is the photon's survival
// probability. Zero for degenerate input.
vec4 bsdf_albedo_weights(Bsdf bsdf, vec3 wo, vec3 n_s, vec3 n_g) {
    BsdfOriented o;
    if (!bsdf_orient(bsdf, wo, n_s, n_g, o)) {
        return vec4(0.0);
    }
    vec3 c[4];
    bsdf_lobe_reflectances(bsdf, o, c);
    return bsdf_weights_of(c);
}

// cos_i when wi is on the reflection side of both normals, else a value <= 0.
float bsdf_reflected_cos(BsdfOriented o, vec3 wi) {
    float cos_i = dot(wi, o.n);
    return (cos_i >= BSDF_MIN_COS && dot(wi, o.ng) > 0.0) ? min(cos_i, 1.0) : 0.0;
}

// x: glossy shape g without c; y: pdf of wi from the glossy lobe alone. e: the lobe's
// directional albedo bsdf_glossy_albedo(bsdf.exponent, o.cos_o), which depends on the view alone.
vec2 bsdf_glossy_shape_and_pdf_with_albedo(Bsdf bsdf, BsdfOriented o, vec3 wi, float cos_i,
                                           float e) {
    vec3 h;
    if (!bsdf_unit(o.wo + wi, h)) {
        return vec2(0.0);
    }
    float wo_h = dot(o.wo, h);
    if (wo_h <= 0.0) {
        return vec2(0.0);
    }
    float d = blinn_phong_half_vector_pdf(dot(h, o.n), bsdf.exponent);
    return vec2(d / (4.0 * wo_h * max(o.cos_o, cos_i) * e), d / (4.0 * wo_h));
}

vec2 bsdf_glossy_shape_and_pdf(Bsdf bsdf, BsdfOriented o, vec3 wi, float cos_i) {
    return bsdf_glossy_shape_and_pdf_with_albedo(bsdf, o, wi, cos_i,
                                                 bsdf_glossy_albedo(bsdf.exponent, o.cos_o));
}

// f of the non-delta lobes, as bsdf_eval_and_pdf_oriented gives it, with the glossy lobe's
// directional albedo e given: a gather that evaluates one view against many photons computes
// e once (photon_tiles.comp).
vec3 bsdf_eval_oriented_with_albedo(Bsdf bsdf, BsdfOriented o, vec3 c[4], vec4 w, float e,
                                    vec3 wi, float cos_i) {
    if (w.x + w.y + w.z + w.w <= 0.0) {
        return vec3(0.0);
    }
    vec3 f = c[LOBE_LAMBERTIAN] * (1.0 / PI);
    if (BSDF_GLOSSY_LOBE && w[LOBE_GLOSSY] > 0.0) {
        f += c[LOBE_GLOSSY] * bsdf_glossy_shape_and_pdf_with_albedo(bsdf, o, wi, cos_i, e).x;
    }
    return f;
}

// f (non-delta lobes) and the mixture pdf of wi, sharing the glossy lobe's evaluation.
void bsdf_eval_and_pdf_oriented(Bsdf bsdf, BsdfOriented o, vec3 c[4], vec4 w, vec3 wi,
                                float cos_i, out vec3 f, out float pdf) {
    f = vec3(0.0);
    pdf = 0.0;
    float total = w.x + w.y + w.z + w.w;
    if (total <= 0.0) {
        return;
    }
    f = c[LOBE_LAMBERTIAN] * (1.0 / PI);
    pdf = w[LOBE_LAMBERTIAN] * cosine_hemisphere_pdf(cos_i);
    if (BSDF_GLOSSY_LOBE && w[LOBE_GLOSSY] > 0.0) {
        vec2 glossy = bsdf_glossy_shape_and_pdf(bsdf, o, wi, cos_i);
        f += c[LOBE_GLOSSY] * glossy.x;
        pdf += w[LOBE_GLOSSY] * glossy.y;
    }
    pdf /= total;
}

// f(wo, wi) of the non-delta lobes, without the cosine.
vec3 bsdf_eval(Bsdf bsdf, vec3 wo, vec3 wi, vec3 n_s, vec3 n_g) {
    BsdfOriented o;
    vec3 w;
    if (!bsdf_orient(bsdf, wo, n_s, n_g, o) || !bsdf_unit(wi, w)) {
        return vec3(0.0);
    }
    float cos_i = bsdf_reflected_cos(o, w);
    if (cos_i <= 0.0) {
        return vec3(0.0);
    }
    vec3 c[4];
    bsdf_lobe_reflectances(bsdf, o, c);
    vec3 f;
    float pdf;
    bsdf_eval_and_pdf_oriented(bsdf, o, c, bsdf_weights_of(c), w, cos_i, f, pdf);
    return f;
}

// Solid-angle pdf of bsdf_sample through a non-delta lobe, with the lobe-selection probability.
float bsdf_pdf(Bsdf bsdf, vec3 wo, vec3 wi, vec3 n_s, vec3 n_g) {
    BsdfOriented o;
    vec3 w;
    if (!bsdf_orient(bsdf, wo, n_s, n_g, o) || !bsdf_unit(wi, w)) {
        return 0.0;
    }
    float cos_i = bsdf_reflected_cos(o, w);
    if (cos_i <= 0.0) {
        return 0.0;
    }
    vec3 c[4];
    bsdf_lobe_reflectances(bsdf, o, c);
    vec3 f;
    float pdf;
    bsdf_eval_and_pdf_oriented(bsdf, o, c, bsdf_weights_of(c), w, cos_i, f, pdf);
    return pdf;
}

// Direction of `lobe` alone; writes eta crossed (1 when reflected, also under TIR).
bool bsdf_sample_direction(Bsdf bsdf, uint lobe, BsdfOriented o, vec2 u, out vec3 wi,
                           out float eta) {
    eta = 1.0;
    wi = vec3(0.0);
    vec3 w;
    if (lobe == LOBE_LAMBERTIAN) {
        w = frame_to_world(o, cosine_hemisphere(u));
    } else if (BSDF_GLOSSY_LOBE && lobe == LOBE_GLOSSY) {
        vec3 h = frame_to_world(o, blinn_phong_half_vector(u, bsdf.exponent));
        float wo_h = dot(o.wo, h);
        if (wo_h <= 0.0) {
            return false;
        }
        w = 2.0 * wo_h * h - o.wo;
    } else if (BSDF_DELTA_LOBES && lobe == LOBE_MIRROR) {
        w = bsdf_reflect(o.wo, o.n);
    } else if (BSDF_DELTA_LOBES && lobe == LOBE_REFRACTION) {
        if (o.eta == 1.0) {
            wi = -o.wo;
            return true;
        }
        float sin2_t = (1.0 - o.cos_o * o.cos_o) / (o.eta * o.eta);
        if (sin2_t >= 1.0) {
            wi = bsdf_reflect(o.wo, o.n);
            return dot(wi, o.ng) > 0.0;
        }
        float cos_t = sqrt(1.0 - sin2_t);
        if (!bsdf_unit(-o.wo / o.eta + (o.cos_o / o.eta - cos_t) * o.n, wi)) {
            return false;
        }
        eta = o.eta;
        return dot(wi, o.ng) < 0.0;
    } else {
        return false;
    }
    if (!bsdf_unit(w, wi)) {
        return false;
    }
    return bsdf_reflected_cos(o, wi) > 0.0;
}

// Samples `lobe` alone: weight = c * g cos / pdf_lobe (delta: c), pdf of the lobe alone
// (delta: 1).
bool bsdf_sample_lobe(Bsdf bsdf, uint lobe, vec3 wo, vec3 n_s, vec3 n_g, vec2 u,
                      out BsdfSample s) {
    s = BsdfSample(vec3(0.0), vec3(0.0), 0.0, lobe, 1.0, 0.0);
    BsdfOriented o;
    if (!bsdf_orient(bsdf, wo, n_s, n_g, o)) {
        return false;
    }
    vec3 cs[4];
    bsdf_lobe_reflectances(bsdf, o, cs);
    vec3 c = cs[lobe];
    if (bsdf_mean(c) <= 0.0) {
        return false;
    }
    vec3 wi;
    float eta;
    if (!bsdf_sample_direction(bsdf, lobe, o, u, wi, eta)) {
        return false;
    }
    vec3 weight = c;
    float pdf = 1.0;
    if (lobe == LOBE_LAMBERTIAN) {
        pdf = cosine_hemisphere_pdf(dot(wi, o.n));
    } else if (BSDF_GLOSSY_LOBE && lobe == LOBE_GLOSSY) {
        float cos_i = min(dot(wi, o.n), 1.0);
        pdf = bsdf_glossy_shape_and_pdf(bsdf, o, wi, cos_i).y;
        weight = c * (cos_i / (max(o.cos_o, cos_i) * bsdf_glossy_albedo(bsdf.exponent, o.cos_o)));
    }
    if (!(pdf > 0.0) || isinf(pdf)) {
        return false;
    }
    s = BsdfSample(wi, weight, pdf, lobe, eta, path_density_factor(lobe, c));
    return true;
}

// The lobe whose cumulative weight interval holds x; never a zero-weight lobe.
uint bsdf_choose_lobe(vec4 w, float x) {
    float cumulative = 0.0;
    uint last = LOBE_LAMBERTIAN;
    for (uint lobe = 0u; lobe < 4u; ++lobe) {
        if (w[lobe] <= 0.0) {
            continue;
        }
        last = lobe;
        cumulative += w[lobe];
        if (x < cumulative) {
            return lobe;
        }
    }
    return last;
}

// Path-tracer sampling: lobe by u.x in proportion to the albedo weights, direction by u.yz;
// weight = f cos / pdf over all non-delta lobes (delta: c / p).
bool bsdf_sample(Bsdf bsdf, vec3 wo, vec3 n_s, vec3 n_g, vec3 u, out BsdfSample s) {
    s = BsdfSample(vec3(0.0), vec3(0.0), 0.0, LOBE_LAMBERTIAN, 1.0, 0.0);
    BsdfOriented o;
    if (!bsdf_orient(bsdf, wo, n_s, n_g, o)) {
        return false;
    }
    vec3 c[4];
    bsdf_lobe_reflectances(bsdf, o, c);
    vec4 w = bsdf_weights_of(c);
    float total = w.x + w.y + w.z + w.w;
    if (total <= 0.0) {
        return false;
    }
    uint lobe = bsdf_choose_lobe(w, u.x * total);
    vec3 wi;
    float eta;
    if (!bsdf_sample_direction(bsdf, lobe, o, u.yz, wi, eta)) {
        return false;
    }
    float density = path_density_factor(lobe, c[lobe]);
    if (BSDF_DELTA_LOBES && (lobe == LOBE_MIRROR || lobe == LOBE_REFRACTION)) {
        float p = w[lobe] / total;
        s = BsdfSample(wi, c[lobe] / p, p, lobe, eta, density);
        return true;
    }
    float cos_i = min(dot(wi, o.n), 1.0);
    vec3 f;
    float pdf;
    bsdf_eval_and_pdf_oriented(bsdf, o, c, w, wi, cos_i, f, pdf);
    if (!(pdf > 0.0) || isinf(pdf)) {
        return false;
    }
    s = BsdfSample(wi, f * (cos_i / pdf), pdf, lobe, eta, density);
    return true;
}

// Photon scattering with the paper's Russian roulette: absorbed (false) when u.x >= sum of the
// albedo weights; else lobe j with probability w_j, weight = c_j * (g_j cos / pdf_j) / w_j.
bool bsdf_sample_russian_roulette(Bsdf bsdf, vec3 wo, vec3 n_s, vec3 n_g, vec3 u,
                                  out BsdfSample s) {
    s = BsdfSample(vec3(0.0), vec3(0.0), 0.0, LOBE_LAMBERTIAN, 1.0, 0.0);
    vec4 w = bsdf_albedo_weights(bsdf, wo, n_s, n_g);
    if (u.x >= w.x + w.y + w.z + w.w) {
        return false;
    }
    uint lobe = bsdf_choose_lobe(w, u.x);
    if (!bsdf_sample_lobe(bsdf, lobe, wo, n_s, n_g, u.yz, s)) {
        return false;
    }
    float p = w[lobe];
    s.weight /= p;
    s.pdf *= p;
    return true;
}

#endif
