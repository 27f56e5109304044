#version 460
// Bounce map: the first bounce of every photon, on the GPU. Each light G-buffer texel is where
// the photon through that texel hits the scene; it carries the light's power through the texel
// (exact solid angle × spot falloff, or irradiance × area for directional lights), and scatters
// once by importance-sampling the über-BSDF with Russian roulette. Absorbed photons and texels
// that saw nothing are written with zero power. A light's caustic views (src/plan/bounce_plan.rs, "Caustic
// views") subdivide the texels of its main views around mirrors and glass: a main texel and its
// k × k caustic texels share its power, each direction counted once.
#include "shared.glsl"
#include "packing.glsl"
#include "rng.glsl"
#include "material.glsl"
#include "lights.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, set = 0, binding = 0) readonly buffer Materials { GpuMaterial materials[]; };
layout(std430, set = 0, binding = 1) readonly buffer Views { BounceView views[]; };
layout(set = 0, binding = 2) uniform sampler2DArray g_position;
layout(set = 0, binding = 3) uniform sampler2DArray g_normal;
layout(set = 0, binding = 4) uniform sampler2DArray g_albedo;
layout(set = 0, binding = 5) uniform usampler2DArray g_material;
layout(std430, set = 0, binding = 6) writeonly buffer BounceMap {
    PackedBounceMapPhoton bounce_map[];
};

// The map may be split over buffers (src/passes/bounce_map.rs, Split): this dispatch writes
// records first_record .. first_record + records of the map, which lie in the bound buffer,
// whose first record is record `base` of the map.
layout(push_constant) uniform Push {
    uint seed;          // the renderer's --seed
    uint first_view;    // the dispatch's first view (gl_GlobalInvocationID.z counts from it)
    uint first_record;
    uint records;
    uint base;
    uint first_row;     // the first row of the views' texels (gl_GlobalInvocationID.y counts from it)
    uint sample_index;  // the frame's photon sample (texel_jitter; 0 unless accumulating)
    uint pad2;
} push;

// Whether light G-buffer texel `t` saw a surface of a material with a delta lobe (mirror or
// refraction: Material::has_delta_lobe).
bool first_hit_is_delta(ivec3 t) {
    if (texelFetch(g_position, t, 0).w == 0.0) {
        return false;
    }
    GpuMaterial m = materials[texelFetch(g_material, t, 0).x];
    bool mirror = max(m.glossy.r, max(m.glossy.g, m.glossy.b)) > 0.0 && m.glossy.a >= 1e20;
    return mirror || max(m.transmission.r, max(m.transmission.g, m.transmission.b)) > 0.0;
}

// The random-number key of texel xy of `view`: the twin of BouncePlan::texel_key (src/plan/bounce_plan.rs),
// which says why: the light's seed, which of its views this is, and the texel in the view's
// grid (a caustic view's in its parent's grid subdivided k x k), never its bounce-map index.
uint texel_key(BounceView view, uvec2 xy) {
    uvec2 g = xy;
    if (view.kind.y == BOUNCE_VIEW_CAUSTIC) {
        BounceView parent = views[view.kind.z];
        vec2 corner = (view.params.zw - parent.params.zw) / view.params.x;
        g += uvec2(ivec2(round(corner)));
    }
    return hash2(hash2(hash2(view.texels.w, view.kind.w), g.x), g.y);
}

// Where inside its texel the photon of sample `sample_index` passes, in texels from its corner:
// the twin of bounce_plan::texel_jitter (src/plan/bounce_plan.rs), bit for bit (32-bit fixed point).
vec2 texel_jitter(uint key, uint sample_index) {
    uint x = hash2(key, JITTER_STREAM_X) + sample_index * JITTER_R2_X;
    uint y = hash2(key, JITTER_STREAM_Y) + sample_index * JITTER_R2_Y;
    return vec2(uvec2(x, y) >> 8u) * (1.0 / 16777216.0);
}

// Whether light G-buffer texel `t` continues the surface of the texel at `p` with normal `n`
// and material `material`: it saw a surface of the same material whose normal is within about
// 25 degrees and which lies within about 15 degrees of the tangent plane at `p` (a crease or a
// silhouette is not interpolated across).
bool same_surface(ivec3 t, vec3 p, vec3 n, uint material) {
    vec4 q = texelFetch(g_position, t, 0);
    if (q.w == 0.0 || texelFetch(g_material, t, 0).x != material) {
        return false;
    }
    vec3 d = q.xyz - p;
    vec3 m = normalize(texelFetch(g_normal, t, 0).xyz);
    return dot(m, n) > 0.9 && abs(dot(d, n)) <= 0.25 * length(d);
}

// Whether the texel with key `key` sends its photon in sample `sample_index` when its view keeps
// texels with probability `keep` (module docs of src/plan/bounce_plan.rs, "Budget"): the twin of
// bounce_plan::texel_kept (src/plan/bounce_plan.rs), bit for bit.
bool texel_kept(uint key, uint sample_index, float keep) {
    uint bits = hash2(key, KEEP_STREAM) + sample_index * KEEP_R1;
    return float(bits >> 8u) * (1.0 / 16777216.0) < keep;
}

// The direction from the light through the centre of texel xy of `view`, towards the texel's
// first hit `hit` if it saw one (its w not 0).
vec3 texel_direction(BounceView view, uvec2 xy, vec4 hit) {
    if (view.kind.x == LIGHT_DIRECTIONAL) {
        return view.axis.xyz;
    }
    if (hit.w != 0.0) {
        return normalize(hit.xyz - view.light.xyz);
    }
    vec2 ndc = (vec2(xy) + 0.5) / vec2(view.texels.xy) * 2.0 - 1.0;
    vec4 far_h = view.inv_view_proj * vec4(ndc, LIGHT_VIEW_FAR_Z, 1.0);
    return normalize(far_h.xyz / far_h.w - view.light.xyz);
}

void main() {
    uint v = push.first_view + gl_GlobalInvocationID.z;
    BounceView view = views[v];
    uvec2 size = view.texels.xy;
    uvec2 xy = gl_GlobalInvocationID.xy + uvec2(0, push.first_row);
    if (xy.x >= size.x || xy.y >= size.y) {
        return;
    }
    uint record = view.texels.z + xy.y * size.x + xy.x;
    // Another dispatch writes it (into another buffer). Unsigned: below first_record wraps.
    if (record - push.first_record >= push.records) {
        return;
    }
    uint index = record - push.base;
    ivec3 texel = ivec3(xy, int(v));
    // A record with eta 0 sent no photon (outside the cone, not kept this frame, or its power
    // carried by other texels); one with eta 1 and no power sent one that met nothing or was
    // absorbed at its first hit (the CPU counts the photons sent: FrameStats::emitted_photons).
    BounceMapPhoton photon = BounceMapPhoton(vec3(0.0), vec3(0.0), 0.0, 0.0);
    vec4 pos = texelFetch(g_position, texel, 0);
    uint key = texel_key(view, xy);

    // What the light sends through the texel. The texel centre on the view's plane (unit
    // distance, or metres for orthographic views).
    float side = view.params.x;
    vec2 q = view.params.zw + (vec2(xy) + 0.5) * side;
    // Where the texel's solid angle and spot falloff are evaluated: its centre, or for a caustic
    // view its parent texel's centre (q, and the direction to the parent's first hit), so that
    // the powers still sum to the light's flux exactly.
    vec3 emitted = texel_direction(view, xy, pos);
    // The part of the texel's power it carries: every direction counted once (src/plan/bounce_plan.rs,
    // "Caustic views").
    float part = 1.0;
    if (view.kind.y == BOUNCE_VIEW_PARENT) {
        if (first_hit_is_delta(texel)) {
            part = 0.0;
        } else {
            // Its k × k texels in the caustic view that hit a delta material carry their share.
            BounceView child = views[view.kind.z];
            int k = int(round(side / child.params.x));
            ivec2 origin = ivec2(round((child.params.zw - view.params.zw) / side));
            ivec2 first = (ivec2(xy) - origin) * k;
            ivec2 child_size = ivec2(child.texels.xy);
            if (all(greaterThanEqual(first, ivec2(0))) && all(lessThan(first, child_size))) {
                int hits = 0;
                for (int j = 0; j < k; j++) {
                    for (int i = 0; i < k; i++) {
                        ivec3 t = ivec3(first + ivec2(i, j), int(view.kind.z));
                        hits += first_hit_is_delta(t) ? 1 : 0;
                    }
                }
                part = 1.0 - float(hits) / float(k * k);
            }
        }
    } else if (view.kind.y == BOUNCE_VIEW_CAUSTIC) {
        BounceView parent = views[view.kind.z];
        // The parent texel holding this texel's centre (≥ 1/(2k) texels from its edges).
        ivec2 at = ivec2(floor((q - parent.params.zw) / parent.params.x));
        ivec3 parent_texel = ivec3(at, int(view.kind.z));
        bool inside = all(greaterThanEqual(at, ivec2(0)))
            && all(lessThan(at, ivec2(parent.texels.xy)));
        if (!inside || !(first_hit_is_delta(texel) || first_hit_is_delta(parent_texel))) {
            part = 0.0;
        }
        // 1/k² of the parent texel's power (side² = parent side² / k²), evaluated as the parent
        // evaluates it (towards its own first hit), so that the split is exact.
        q = parent.params.zw + (vec2(at) + 0.5) * parent.params.x;
        emitted = texel_direction(parent, uvec2(max(at, ivec2(0))),
                                  texelFetch(g_position, parent_texel, 0));
    }
    vec3 power = vec3(0.0);
    if (view.kind.x == LIGHT_DIRECTIONAL) {
        // Orthographic: irradiance times the texel's area.
        power = view.intensity.rgb * side * side * part;
    } else {
        // Solid angle of the texel: its area on the plane at unit distance, foreshortened.
        float omega = side * side / pow(1.0 + dot(q, q), 1.5);
        power = view.intensity.rgb * omega * part;
        power *= light_falloff(view.kind.x, view.intensity.w, view.axis.w,
                               dot(view.axis.xyz, emitted));
    }
    // The budget: the texel sends its photon with probability keep, which then carries 1/keep
    // of its power (src/plan/bounce_plan.rs, "Budget").
    float keep = view.params.y;
    if (!(part > 0.0) || !any(greaterThan(power, vec3(0.0)))
        || !texel_kept(key, push.sample_index, keep)) {
        bounce_map[index] = bounce_map_photon_store(photon);
        return;
    }
    power /= keep;
    photon.eta = 1.0;
    if (pos.w == 0.0) {
        // Sent, and met nothing.
        bounce_map[index] = bounce_map_photon_store(photon);
        return;
    }

    // Where it hits. The photon passes through a jittered point of its texel (texel_jitter):
    // its hit is where that ray meets the plane of the triangle the texel saw (its face normal),
    // and its shading normal is the bilinear interpolation of the neighbouring texels' normals
    // on the same surface, so a curved mirror reflects a continuous fan of directions, not one
    // per texel.
    vec3 centre = pos.xyz;
    vec4 nrm = texelFetch(g_normal, texel, 0);
    vec3 n_centre = normalize(nrm.xyz);
    vec3 face = gbuffer_face_normal(nrm, texelFetch(g_albedo, texel, 0));
    uint material = texelFetch(g_material, texel, 0).x;
    vec2 jitter = texel_jitter(key, push.sample_index);
    vec2 ndc = (vec2(xy) + jitter) / vec2(size) * 2.0 - 1.0;
    vec4 near_h = view.inv_view_proj * vec4(ndc, LIGHT_VIEW_NEAR_Z, 1.0);
    vec4 far_h = view.inv_view_proj * vec4(ndc, LIGHT_VIEW_FAR_Z, 1.0);
    vec3 near_point = near_h.xyz / near_h.w;
    vec3 ray = normalize(far_h.xyz / far_h.w - near_point);
    float facing = dot(ray, face);
    // Grazing rays (within about 6 degrees of the plane) take the point nearest the texel's.
    float depth = facing * facing > 0.01 ? dot(centre - near_point, face) / facing
                                         : dot(centre - near_point, ray);
    if (!(depth > 0.0) || isinf(depth)) {
        depth = length(centre - near_point);
    }
    photon.depth = depth;
    vec3 p = near_point + ray * depth;
    // Bilinear weights of the four texel centres around the jittered point.
    vec2 f = vec2(xy) + jitter - 0.5;
    ivec2 base = ivec2(floor(f));
    vec2 w = f - vec2(base);
    vec3 n_sum = vec3(0.0);
    for (int j = 0; j < 2; j++) {
        for (int i = 0; i < 2; i++) {
            ivec2 c = base + ivec2(i, j);
            float weight = (i == 0 ? 1.0 - w.x : w.x) * (j == 0 ? 1.0 - w.y : w.y);
            if (c == ivec2(xy)) {
                n_sum += weight * n_centre;
            } else if (all(greaterThanEqual(c, ivec2(0))) && all(lessThan(c, ivec2(size)))
                       && same_surface(ivec3(c, int(v)), centre, n_centre, material)) {
                n_sum += weight * normalize(texelFetch(g_normal, ivec3(c, int(v)), 0).xyz);
            }
        }
    }
    vec3 n_interp = normalize(n_sum);

    vec3 travel = view.kind.x == LIGHT_DIRECTIONAL ? view.axis.xyz : normalize(p - view.light.xyz);

    // The mesh's own side: refraction needs to know whether the photon enters or leaves.
    vec3 n = n_interp * (nrm.w < 0.0 ? -1.0 : 1.0);
    vec3 albedo = texelFetch(g_albedo, texel, 0).rgb;
    GpuMaterial m = materials[material];
    Bsdf bsdf = material_bsdf(m, albedo);
    Rng rng = rng_new(hash2(key, push.seed));
    BsdfSample s;
    if (bsdf_sample_russian_roulette(bsdf, -travel, n, n, rng_next_3(rng), s)) {
        photon.power = power * s.weight;
        photon.direction = pack_direction(s.wi, s.path_density_factor);
        photon.eta = s.eta;
    }
    bounce_map[index] = bounce_map_photon_store(photon);
}
