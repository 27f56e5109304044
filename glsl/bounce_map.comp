#version 460
// Bounce map: the first bounce of every photon, on the GPU. Each light G-buffer texel is where
// the photon through that texel hits the scene; it carries the light's power through the texel
// (exact solid angle × spot falloff, or irradiance × area for directional lights), and scatters
// once by importance-sampling the über-BSDF with Russian roulette. Absorbed photons and texels
// that saw nothing are written with zero power.
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

layout(push_constant) uniform Push {
    uint seed;  // the renderer's --seed
    uint pad0;
    uint pad1;
    uint pad2;
} push;

void main() {
    BounceView view = views[gl_GlobalInvocationID.z];
    uint res = view.texels.x;
    uvec2 xy = gl_GlobalInvocationID.xy;
    if (xy.x >= res || xy.y >= res) {
        return;
    }
    uint index = view.texels.y + xy.y * res + xy.x;
    ivec3 texel = ivec3(xy, int(gl_GlobalInvocationID.z));
    BounceMapPhoton photon = BounceMapPhoton(vec3(0.0), vec3(0.0), 1.0, 0.0);
    vec4 pos = texelFetch(g_position, texel, 0);
    if (pos.w == 0.0) {
        bounce_map[index] = bounce_map_photon_store(photon);
        return;
    }
    vec3 p = pos.xyz;
    vec2 ndc = (vec2(xy) + 0.5) / float(res) * 2.0 - 1.0;
    vec4 near_h = view.inv_view_proj * vec4(ndc, 0.0, 1.0);
    vec3 near_point = near_h.xyz / near_h.w;

    vec3 travel;
    vec3 power;
    if (view.params.y > 0.5) {
        // Orthographic (directional): irradiance times the texel's area.
        travel = view.axis.xyz;
        power = view.intensity.rgb * view.params.x;
    } else {
        travel = normalize(p - view.light.xyz);
        // Solid angle of the texel: its area on the plane at unit distance, foreshortened.
        vec2 q = ndc * view.params.x;
        float side = 2.0 * view.params.x / float(res);
        float omega = side * side / pow(1.0 + dot(q, q), 1.5);
        power = view.intensity.rgb * omega;
        if (view.texels.z == LIGHT_SPOT) {
            power *= spot_falloff_cos(view.intensity.w, view.axis.w, dot(view.axis.xyz, travel));
        }
    }

    vec4 nrm = texelFetch(g_normal, texel, 0);
    // The mesh's own side: refraction needs to know whether the photon enters or leaves.
    vec3 n = normalize(nrm.xyz) * (nrm.w < 0.0 ? -1.0 : 1.0);
    vec3 albedo = texelFetch(g_albedo, texel, 0).rgb;
    GpuMaterial m = materials[texelFetch(g_material, texel, 0).x];
    Bsdf bsdf = material_bsdf(m, albedo);
    Rng rng = rng_new(hash2(hash2(view.texels.w, index), push.seed));
    BsdfSample s;
    if (any(greaterThan(power, vec3(0.0)))
        && bsdf_sample_russian_roulette(bsdf, -travel, n, n, rng_next_3(rng), s)) {
        photon.power = power * s.weight;
        photon.direction = pack_direction(s.wi, s.path_density_factor);
        photon.eta = s.eta;
    }
    photon.depth = length(p - near_point);
    bounce_map[index] = bounce_map_photon_store(photon);
}
