#version 460
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_shuffle : require
#extension GL_KHR_shader_subgroup_vote : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_arithmetic : require
// Tiled density estimation (--density tiled; src/passes/photon_tiles.rs has the picture): the
// same radiance estimate as the photon volumes (photon_volumes.frag, and at --subsample N > 1
// photon_volumes_subsampled.frag), gathered instead of splatted. One workgroup is one screen
// tile of PHOTON_TILE² pixels; the CPU listed, per tile, the photons whose kernel's bounding sphere
// may cover one of its pixels (src/render/photon_frame/tiles.rs). Each subgroup reads its tile's list
// a subgroup's width at a time, keeps the photons whose sphere reaches the box around its
// pixels' surface points, and passes them lane to lane (subgroupShuffle: no shared memory and
// no barrier, which llvmpipe makes expensive); each pixel sums what the
// fragment shader would have added had the volume covered it: the kernel test, the
// same-surface rule, the front-side test and the regularised BSDF, set up once per pixel
// instead of once per fragment. Outputs and their channels are the fragment shaders' (with
// additive blending's sums): at full resolution indirect, global, weight; at 1/N irradiance,
// glossy, global, weight. A dispatch gathers at most TILE_JOB entries of each tile's list
// (lavapipe ends an invocation's loops after 65535 iterations in all, so a caustic's focus
// tile of 200k entries would silently lose photons): longer lists, and further photon buffers,
// take further dispatches, each after the first continuing the sums where the last one left
// them (push.accumulate), in list order, so the sum is the one a single dispatch would make.
#include "shared.glsl"
#include "packing.glsl"
#include "kernel.glsl"
#include "material.glsl"

layout(local_size_x = PHOTON_TILE, local_size_y = PHOTON_TILE) in;

layout(set = 0, binding = 0) uniform Frame { FrameUniforms frame; };
layout(std430, set = 0, binding = 1) readonly buffer Photons { PackedPhoton photons[]; };
layout(std430, set = 0, binding = 2) readonly buffer Materials { GpuMaterial materials[]; };
layout(set = 0, binding = 3) uniform sampler2D g_position;
layout(set = 0, binding = 4) uniform sampler2D g_normal;
layout(set = 0, binding = 5) uniform sampler2D g_albedo;
layout(set = 0, binding = 6) uniform usampler2D g_material;
// Per tile t of photon buffer b: its list is indices[offsets[first + t] .. offsets[first + t + 1]]
// with first = b·(tiles + 1), each entry a photon of that buffer.
layout(std430, set = 0, binding = 7) readonly buffer TileOffsets { uint offsets[]; };
layout(std430, set = 0, binding = 8) readonly buffer TileIndices { uint indices[]; };
layout(set = 0, binding = 9, rgba32f) uniform image2D out0;   // indirect | irradiance
layout(set = 0, binding = 10, rgba32f) uniform image2D out1;  // global | glossy
layout(set = 0, binding = 11, rgba32f) uniform image2D out2;  // weight | global
layout(set = 0, binding = 12, rgba32f) uniform image2D out3;  // unused | weight
// Per photon of the map: its kernel's bounding sphere (eye-relative centre, radius a little
// wider than kernel_radius's; 0: never reached), made on the CPU with the lists, in half floats
// (lists.rs, pack_sphere: centre x | y, centre z | radius; rounded outwards).
layout(std430, set = 0, binding = 13) readonly buffer Spheres { uvec2 spheres[]; };

// The estimate runs on the 1/N grid (`--subsample N > 1`).
layout(constant_id = SPEC_ID_SUBSAMPLED) const bool SUBSAMPLED = false;

layout(push_constant) uniform Push {
    float r_min;
    float r_max;
    uint tile_columns;
    uint subsample;
    float footprint;
    float footprint_max;
    float scale;
    float gather_exponent_max;
    vec4 offset;  // xyz: photon map origin − eye
    uint width;   // the targets'
    uint height;
    uint first;   // this buffer's first entry in offsets
    uint accumulate;  // 1: continue the targets' sums (not the first dispatch)
    uint start;   // the first entry of each tile's list this dispatch gathers, from its start
    uint photon_base;  // this buffer's first photon's index in spheres
    // 1: the fine photons at full resolution, added to out0 (the indirect image the upsample
    // wrote); no other target is read or written (they may all be out0).
    uint fine;
    // Workgroup i (row-major) gathers tile offsets[tile_list + i], for i < listed: the tiles
    // in the order the host chose (passes/photon_tiles/order.rs: on lavapipe, which gives
    // each thread one block of consecutive workgroups, one that spreads the cost evenly).
    uint tile_list;
    uint listed;
    uint pad2;
    uint pad3;
    uint pad4;
} push;

void store(ivec2 px, vec4 a, vec4 b, vec4 c, vec4 d) {
    imageStore(out0, px, a);
    imageStore(out1, px, b);
    imageStore(out2, px, c);
    if (SUBSAMPLED) {
        imageStore(out3, px, d);
    }
}

// The pixel's surface, set up once (main), and its sums: per invocation.
vec3 pos;
vec3 n_s = vec3(0.0, 0.0, 1.0);
Bsdf bsdf;
BsdfOriented o;
vec3 c[4];
vec4 weights = vec4(0.0);
float glossy_albedo = 1.0;
bool oriented = false;
vec3 lambert = vec3(0.0);
// Full resolution: total (rgb, volumes counted), global (rgb, Σ κ·r), Σ κ.
// 1/N: Σ Φκ (and count), glossy, global Φκ (and Σ κ·r), Σ κ and the global glossy share.
vec4 sum0 = vec4(0.0);
vec3 glossy_sum = vec3(0.0);
vec4 global_sum = vec4(0.0);
float kappa_sum = 0.0;
vec3 global_glossy = vec3(0.0);

// Adds what the photon volume's fragment shader adds at this pixel (photon_volumes.frag, or
// at 1/N photon_volumes_subsampled.frag) for a photon whose kernel's bounding sphere
// (centre.xyz, r_xy = centre.w) contains the shaded point: no subgroup operation, so lanes may
// leave it early.
void add_photon(vec4 centre, vec4 normal, vec4 power, vec3 wi) {
    float kappa = kernel_weight(centre.xyz, normal.xyz, centre.w, normal.w, pos);
    if (!(kappa > 0.0)) {
        return;
    }
    bool global_photon = power.w > 0.5;
    if (global_photon && abs(dot(normal.xyz, n_s)) < SUPPORT_NORMAL_COS) {
        return;
    }
    vec3 f = vec3(0.0);
    if (!SUBSAMPLED) {
        // photon_volumes.frag: the front-side test, then bsdf_eval (which normalises wi).
        if (dot(wi, n_s) <= 0.0) {
            return;
        }
        vec3 w;
        float cos_i = (oriented && bsdf_unit(wi, w)) ? bsdf_reflected_cos(o, w) : 0.0;
        if (cos_i > 0.0) {
            f = bsdf_eval_oriented_with_albedo(bsdf, o, c, weights, glossy_albedo, w, cos_i);
        }
        vec3 contribution = f * power.rgb * kappa;
        sum0 += vec4(contribution, 1.0);
        if (global_photon) {
            global_sum += vec4(contribution, kappa * centre.w);
            kappa_sum += kappa;
        }
    } else {
        if (!oriented) {
            return;
        }
        float cos_i = bsdf_reflected_cos(o, wi);
        if (cos_i <= 0.0) {
            return;
        }
        f = bsdf_eval_oriented_with_albedo(bsdf, o, c, weights, glossy_albedo, wi, cos_i);
        vec3 flux = power.rgb * kappa;
        vec3 glossy = max(f - lambert, vec3(0.0)) * flux;
        sum0 += vec4(flux, 1.0);
        glossy_sum += glossy;
        if (global_photon) {
            global_sum += vec4(flux, kappa * centre.w);
            kappa_sum += kappa;
            global_glossy += glossy;
        }
    }
}

void main() {
    uint listed_index = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    if (listed_index >= push.listed) {
        return;  // past the last listed tile (the same for the whole workgroup)
    }
    uint tile = offsets[push.tile_list + listed_index];
    uvec2 tile_xy = uvec2(tile % push.tile_columns, tile / push.tile_columns);
    ivec2 px = ivec2(tile_xy * uvec2(PHOTON_TILE) + gl_LocalInvocationID.xy);
    bool inside = px.x < int(push.width) && px.y < int(push.height);
    // The G-buffer pixel this one shades: itself, or at 1/N the centre of its N×N block (as in
    // photon_volumes_subsampled.frag and upsample.comp's subsample_centre).
    int n = int(push.subsample);
    ivec2 g = SUBSAMPLED ? min(px * n + n / 2, ivec2(frame.counts.zw) - 1) : px;
    // Adding to the sums the targets hold: those of the dispatches before, or the estimate
    // the fine photons are added to.
    bool adding = push.accumulate != 0u || push.fine != 0u;

    uint list_begin = offsets[push.first + tile];
    uint list_end = offsets[push.first + tile + 1u];
    uint begin = list_begin + push.start;
    if (begin >= list_end) {
        // Nothing (left) in this tile's list, the same for the whole workgroup: the first
        // dispatch clears the sums, one that adds leaves them. First of all, for an empty tile
        // needs nothing else (the background's tiles, and those a later job finds done).
        if (!adding && inside) {
            store(px, vec4(0.0), vec4(0.0), vec4(0.0), vec4(0.0));
        }
        return;
    }

    vec4 position = inside ? texelFetch(g_position, g, 0) : vec4(0.0);
    pos = position.xyz;
    bool shaded = inside && position.w != 0.0;

    // Once per pixel: the surface, its regularised BSDF oriented to the eye, its lobes.
    if (shaded) {
        n_s = normalize(texelFetch(g_normal, g, 0).xyz);
        GpuMaterial m = materials[texelFetch(g_material, g, 0).x];
        bsdf = bsdf_regularized(material_bsdf(m, texelFetch(g_albedo, g, 0).rgb),
                                push.gather_exponent_max);
        oriented = bsdf_orient(bsdf, normalize(-pos), n_s, n_s, o);
        if (oriented) {
            bsdf_lobe_reflectances(bsdf, o, c);
            weights = bsdf_weights_of(c);
            if (BSDF_GLOSSY_LOBE && weights[LOBE_GLOSSY] > 0.0) {
                glossy_albedo = bsdf_glossy_albedo(bsdf.exponent, o.cos_o);
            }
        }
    }
    lambert = oriented ? c[LOBE_LAMBERTIAN] * (1.0 / PI) : vec3(0.0);

    uint end = min(list_end, begin + TILE_JOB);
    if (adding && inside) {
        // Continue the sums of the dispatches before, in the same order.
        sum0 = imageLoad(out0, px);
        if (push.fine != 0u) {
            // Only out0: the fine photons are caustic ones, which add nothing to the others.
        } else if (SUBSAMPLED) {
            glossy_sum = imageLoad(out1, px).rgb;
            global_sum = imageLoad(out2, px);
            vec4 w = imageLoad(out3, px);
            kappa_sum = w.x;
            global_glossy = w.yzw;
        } else {
            global_sum = imageLoad(out1, px);
            kappa_sum = imageLoad(out2, px).x;
        }
    }
    end = max(end, begin);
    // The box around this subgroup's shaded points: a listed photon whose sphere misses it
    // reaches none of them (most of a tile's list, for a subgroup that is one row of it).
    vec3 box_lo = subgroupMin(shaded ? pos : vec3(3.0e38));
    vec3 box_hi = subgroupMax(shaded ? pos : vec3(-3.0e38));
    if (!subgroupAny(shaded)) {
        end = begin;
    }
    // The subgroup's active lanes, which need not be all gl_SubgroupSize of them (llvmpipe
    // vectorises along x: a workgroup narrower than its vector leaves lanes idle): each reads
    // the entry of its rank among them.
    uvec4 awake = subgroupBallot(true);
    uint lanes = subgroupBallotBitCount(awake);
    uint rank = subgroupBallotExclusiveBitCount(awake);
    for (uint base = begin; base < end; base += lanes) {
        // Each active lane reads one photon of the next `lanes` and tests it against the box;
        // then every lane tests the photons that passed, taking photon j's values from lane j
        // (no shared memory, no barrier).
        uint k = base + rank;
        vec4 my_centre = vec4(0.0);
        vec4 my_normal = vec4(0.0);
        vec4 my_power = vec4(0.0);
        vec4 my_wi = vec4(0.0);
        bool near = false;
        uint index = 0u;
        if (k < end) {
            index = indices[k];
            uvec2 packed = spheres[push.photon_base + index];
            vec4 sphere = vec4(unpackHalf2x16(packed.x), unpackHalf2x16(packed.y));
            vec3 gap = sphere.xyz - clamp(sphere.xyz, box_lo, box_hi);
            near = dot(gap, gap) < sphere.w * sphere.w;
        }
        if (near) {
            Photon photon = photon_load(photons[index]);
            float r_knn;
            unpack_normal(photon.normal, r_knn);
            vec3 normal = normalize(photon.normal);  // as photon_volumes.frag
            vec3 centre = photon.position + push.offset.xyz;
            vec2 r = kernel_radius(r_knn, push.r_min, push.r_max, push.scale, push.footprint,
                                   push.footprint_max, length(centre));
            float rho_p;
            vec3 wi = unpack_direction(photon.direction, rho_p);
            my_centre = vec4(centre, r.x);
            my_normal = vec4(normal, r.y);
            my_power = vec4(photon.power, rho_p > CAUSTIC_PATH_DENSITY ? 0.0 : 1.0);
            my_wi = vec4(wi, 0.0);
        }
        uvec4 ballot = subgroupBallot(near);
        uint count = subgroupBallotBitCount(ballot);
        for (uint m = 0u; m < count; ++m) {
            uint j = subgroupBallotFindLSB(ballot);
            ballot[j >> 5u] &= ~(1u << (j & 31u));
            vec4 centre = subgroupShuffle(my_centre, j);
            vec3 d = pos - centre.xyz;
            bool hit = shaded && dot(d, d) < centre.w * centre.w;
            // The cheap test first: most listed photons miss every pixel here. The branch is
            // uniform, so every lane takes part in the shuffles inside it.
            if (subgroupAny(hit)) {
                vec4 normal = subgroupShuffle(my_normal, j);
                vec4 power = subgroupShuffle(my_power, j);
                vec3 wi = subgroupShuffle(my_wi, j).xyz;
                if (hit) {
                    add_photon(centre, normal, power, wi);
                }
            }
        }
    }
    if (!inside) {
        return;
    }
    if (push.fine != 0u) {
        imageStore(out0, px, sum0);
    } else if (SUBSAMPLED) {
        store(px, sum0, vec4(glossy_sum, 0.0), global_sum, vec4(kappa_sum, global_glossy));
    } else {
        store(px, sum0, global_sum, vec4(kappa_sum, 0.0, 0.0, 0.0), vec4(0.0));
    }
}
