#version 460
// Translucent and mirror surfaces, fragment stage: forward shading over the opaque result.
//   non-delta lobes: shadowed direct light, as the direct pass would give them
//   mirror lobe:     the environment cube maps (direct + the photons' indirect light) in the
//                    reflected direction
//   refraction lobe: the environment cube maps in the refracted direction (Snell, eta of the
//                    side the viewer is on; total internal reflection reflects)
// A reflected or refracted ray first meets the object's own surface (`follow`): the far side
// of a glass, a ring's inner wall in the other, total internal reflection inside a prism,
// traced through a BVH of the mesh's own triangles (src/passes/translucent/object_bvh.rs); each
// surface it meets reflects or refracts it as the über-BSDF says (the heavier lobe followed,
// the other looked up in the environment), until it leaves the object and looks the
// environment up. Other delta objects are not in any probe's cube, nor traced: a ray between two of
// them sees what is behind the other.
// The lobe weights are the über-BSDF's own (bsdf_lobe_reflectances: Fresnel-weighted when the
// material asks for it), so what the eye sees matches what photons do at the surface.
// Lookups are projected onto the scene's bounding box from the centre of the draw's probe
// (env.centre; each probe is its own descriptor set, src/passes/translucent.rs) (parallax
// correction), which is exact for rays that leave through a wall of a box-shaped room.
#include "shared.glsl"
#include "material.glsl"
#include "forward.glsl"

layout(set = 0, binding = 0) uniform Frame { FrameUniforms frame; };
layout(std430, set = 0, binding = 1) readonly buffer Materials { GpuMaterial materials[]; };
layout(std430, set = 0, binding = 2) readonly buffer Lights { GpuLight lights[]; };
layout(std430, set = 0, binding = 3) readonly buffer Views { ShadowView shadow_views[]; };
layout(set = 0, binding = 4) uniform sampler2DArrayShadow shadow_atlas;
layout(set = 0, binding = 5) uniform Environment { EnvironmentUniforms env; };
layout(set = 0, binding = 6) uniform samplerCube environment_map;
// The photons' indirect light from the same centre (src/render/photon_frame/environment.rs).
layout(set = 0, binding = 7) uniform samplerCube environment_indirect;
// The delta meshes' own triangles (src/passes/translucent/object_bvh.rs); this draw's tree is
// draw.material.z - 1 (0: none).
layout(std430, set = 0, binding = 8) readonly buffer ObjectNodes { ObjectNode object_nodes[]; };
layout(std430, set = 0, binding = 9) readonly buffer ObjectTriangles {
    ObjectTriangle object_triangles[];
};
layout(set = 1, binding = 0) uniform sampler2D base_color;
layout(push_constant) uniform Push { DrawPush draw; };

#include "shadows.glsl"

layout(location = 0) in vec3 v_position;
layout(location = 1) in vec3 v_normal;
layout(location = 2) in vec2 v_uv;

layout(location = 0) out vec4 out_radiance;

// Radiance arriving at `p` from direction `dir`, looked up where the ray leaves the scene box.
vec3 environment(vec3 p, vec3 dir) {
    vec3 s = vec3(dir.x < 0.0 ? -1.0 : 1.0, dir.y < 0.0 ? -1.0 : 1.0, dir.z < 0.0 ? -1.0 : 1.0);
    vec3 inv = s / max(abs(dir), vec3(1e-6));
    vec3 t_lo = (env.bounds_min.xyz - p) * inv;
    vec3 t_hi = (env.bounds_max.xyz - p) * inv;
    vec3 t_far = max(t_lo, t_hi);
    float t = min(min(t_far.x, t_far.y), t_far.z);
    vec3 from_centre = p + max(t, 0.0) * dir - env.centre.xyz;
    // Scale case: "at the centre" is relative to the scene's size, not 10^-4 m.
    float at_centre = 1e-4 * length(env.bounds_max.xyz - env.bounds_min.xyz);
    vec3 lookup = dot(from_centre, from_centre) > at_centre * at_centre ? from_centre : dir;
    return texture(environment_map, lookup).rgb
        + env.centre.w * texture(environment_indirect, lookup).rgb;
}

// Surfaces of the object a ray meets before it leaves it, and how many a ray follows.
const int MAX_OWN_SURFACES = 8;
// Depth of the traversal stack: a median-split tree of 2^24 triangles is 23 deep.
const int OBJECT_STACK = 32;

// Where the object-space ray o + t·d (inv = 1/d) enters box `b` within (t_min, t_max), or
// +inf when it misses it.
float box_entry(ObjectNode b, vec3 o, vec3 inv, float t_min, float t_max) {
    vec3 t0 = (b.lo - o) * inv;
    vec3 t1 = (b.hi - o) * inv;
    vec3 near3 = min(t0, t1);
    vec3 far3 = max(t0, t1);
    float near = max(max(near3.x, near3.y), max(near3.z, t_min));
    float far = min(min(far3.x, far3.y), min(far3.z, t_max));
    return near <= far ? near : 1.0 / 0.0;
}

// The closest triangle of the tree at `root` but triangle `skip` that the object-space ray
// o + t·d meets at t in (t_min, t_hit): its t, index (in `hit`), interpolated normal and plane
// normal (`face`; both object space, not unit). Children are visited nearer first; a child is
// skipped when the ray enters it beyond the closest hit found by the time its parent is
// visited. With `first_hit`, the first hit found ends the traversal: for a ray from a point on a
// convex object's surface, whose line meets that surface at most once more, it is the closest.
bool object_hit(uint root, uint skip, vec3 o, vec3 d, float t_min, bool first_hit,
                inout float t_hit, out uint hit, out vec3 n_hit, out vec3 face) {
    // Tiny components (zeros, subnormals) as ±1e-30: no infinity times zero in the slabs.
    vec3 inv = 1.0 / mix(d, mix(vec3(1e-30), vec3(-1e-30), lessThan(d, vec3(0.0))),
                         lessThan(abs(d), vec3(1e-30)));
    uint stack[OBJECT_STACK];
    int depth = 0;
    hit = 0xffffffffu;
    vec2 hit_uv = vec2(0.0);
    n_hit = vec3(0.0);
    face = vec3(0.0);
    uint node = root;
    if (box_entry(object_nodes[root], o, inv, t_min, t_hit) > t_hit) {
        return false;
    }
    while (true) {
        ObjectNode b = object_nodes[node];
        uint first = b.first;
        uint count = b.count;
        if (count == 0u) {
            float a = box_entry(object_nodes[first], o, inv, t_min, t_hit);
            float c = box_entry(object_nodes[first + 1u], o, inv, t_min, t_hit);
            uint near_child = a <= c ? first : first + 1u;
            uint far_child = a <= c ? first + 1u : first;
            float near_t = min(a, c);
            float far_t = max(a, c);
            if (near_t <= t_hit) {
                if (far_t <= t_hit && depth < OBJECT_STACK) {
                    stack[depth++] = far_child;
                }
                node = near_child;
                continue;
            }
        } else {
            for (uint i = first; i < first + count; ++i) {
                if (i == skip) {
                    continue;
                }
                // Möller–Trumbore on the positions alone (the normals are read for the hit).
                vec3 p0 = object_triangles[i].p0.xyz;
                vec3 e1 = object_triangles[i].p1.xyz - p0;
                vec3 e2 = object_triangles[i].p2.xyz - p0;
                vec3 pv = cross(d, e2);
                float det = dot(e1, pv);
                if (abs(det) < 1e-30) {
                    continue;
                }
                float inv_det = 1.0 / det;
                vec3 s = o - p0;
                float u = dot(s, pv) * inv_det;
                vec3 q = cross(s, e1);
                float v = dot(d, q) * inv_det;
                float t = dot(e2, q) * inv_det;
                if (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > t_min && t < t_hit) {
                    t_hit = t;
                    hit = i;
                    hit_uv = vec2(u, v);
                    if (first_hit) {
                        break;
                    }
                }
            }
            if (first_hit && hit != 0xffffffffu) {
                break;
            }
        }
        if (depth == 0) {
            break;
        }
        node = stack[--depth];
    }
    bool found = hit != 0xffffffffu;
    if (found) {
        ObjectTriangle tri = object_triangles[hit];
        n_hit = (1.0 - hit_uv.x - hit_uv.y) * tri.n0.xyz + hit_uv.x * tri.n1.xyz
            + hit_uv.y * tri.n2.xyz;
        face = cross(tri.p1.xyz - tri.p0.xyz, tri.p2.xyz - tri.p0.xyz);
        if (dot(n_hit, n_hit) == 0.0) {
            n_hit = face;
        }
    }
    return found;
}

// True for the pipeline that draws convex objects (`DrawPush::material.w` set, the centre in
// the normal rows' w; `passes/translucent.rs`); the other pipeline, for every other delta
// object, has the shortcut compiled out.
layout(constant_id = SPEC_ID_CONVEX_SHORTCUT) const bool CONVEX_SHORTCUT = false;

// True when a ray along `d` from a point on a face of a convex object, the face's plane
// normal `face` (either way round) and the object's centre `to_centre` away, leaves the object
// through that plane: it meets no more of it (src/passes/translucent/object_bvh.rs, "Convex
// meshes"). False for a degenerate face and for a ray within 10⁻⁴ rad of the plane, whose
// side the plane's own rounding (from screen derivatives at the pixel) could get wrong: the
// traversal decides those.
bool leaves_convex(vec3 d, vec3 face, vec3 to_centre) {
    float along = dot(d, face);
    return along * dot(to_centre, face) < 0.0 && abs(along) > 1e-4 * length(d) * length(face);
}

// Radiance arriving at camera-relative `p` along unit `d`, a ray that has just left this
// draw's object at p (reflected or refracted by it): the object's own surfaces it meets first
// (module comment), then the environment. `face` is the plane normal (camera-relative world,
// either way round) of the face p lies on.
vec3 follow(Bsdf bsdf, vec3 p, vec3 d, vec3 face) {
    uint root = draw.material.z;
    bool convex = CONVEX_SHORTCUT && draw.material.w != 0u;
    // A convex object's centre, object space.
    vec3 centre = vec3(draw.normal0.w, draw.normal1.w, draw.normal2.w);
    if (root == 0u
        || convex && leaves_convex(d, face, (draw.model * vec4(centre, 1.0)).xyz - p)) {
        return environment(p, d);
    }
    // The normal matrix is the inverse transpose of the model's linear part, so its transpose
    // is that part's inverse.
    mat3 normal_matrix = mat3(draw.normal0.xyz, draw.normal1.xyz, draw.normal2.xyz);
    mat3 to_object = transpose(normal_matrix);
    vec3 origin = draw.model[3].xyz;
    // Past the surface the ray starts on: relative to the scene's size, and to the distance
    // from the camera (the rasterised position's own rounding). From the second surface on,
    // the triangle just met is skipped as well: a ray leaving a flat triangle meets it no more.
    float t_min = max(1e-5 * frame.params.y, 4e-7 * length(p));
    uint last = 0xffffffffu;
    vec3 weight = vec3(1.0);
    vec3 sum = vec3(0.0);
    for (int i = 0; i < MAX_OWN_SURFACES; ++i) {
        // t along the object-space ray is the world distance (the map is linear).
        vec3 o = to_object * (p - origin);
        vec3 od = to_object * d;
        float t = 3.4e38;
        vec3 n_object;
        vec3 face_object;
        // Inside a convex object every traversal is of a ray from its surface: the first hit is
        // the only one.
        if (!object_hit(root - 1u, last, o, od, t_min, convex, t, last, n_object, face_object)) {
            return sum + weight * environment(p, d);
        }
        vec3 q = p + t * d;
        vec3 n_mesh = normalize(normal_matrix * n_object);
        vec3 wo = -d;
        BsdfOriented at;
        if (!bsdf_orient(bsdf, wo, n_mesh, n_mesh, at)) {
            return sum;
        }
        vec3 c[4];
        bsdf_lobe_reflectances(bsdf, at, c);
        if (any(greaterThan(c[LOBE_LAMBERTIAN] + c[LOBE_GLOSSY], vec3(0.0)))) {
            vec3 n = dot(n_mesh, wo) < 0.0 ? -n_mesh : n_mesh;
            sum += weight * direct_light(bsdf, q, n, n_mesh, wo);
        }
        vec3 wr = vec3(0.0);
        vec3 wt = vec3(0.0);
        float eta;
        float r = any(greaterThan(c[LOBE_MIRROR], vec3(0.0)))
                && bsdf_sample_direction(bsdf, LOBE_MIRROR, at, vec2(0.0), wr, eta)
            ? dot(c[LOBE_MIRROR], vec3(1.0)) : 0.0;
        float tr = any(greaterThan(c[LOBE_REFRACTION], vec3(0.0)))
                && bsdf_sample_direction(bsdf, LOBE_REFRACTION, at, vec2(0.0), wt, eta)
            ? dot(c[LOBE_REFRACTION], vec3(1.0)) : 0.0;
        if (r + tr <= 0.0) {
            return sum;
        }
        // The heavier lobe goes on through the object; the other looks the environment up.
        if (tr >= r) {
            if (r > 0.0) {
                sum += weight * c[LOBE_MIRROR] * environment(q, wr);
            }
            weight *= c[LOBE_REFRACTION];
            d = wt;
        } else {
            if (tr > 0.0) {
                sum += weight * c[LOBE_REFRACTION] * environment(q, wt);
            }
            weight *= c[LOBE_MIRROR];
            d = wr;
        }
        p = q;
        // The same test in object space, with the plane of the triangle just met.
        if (convex && leaves_convex(to_object * d, face_object, centre - (o + t * od))) {
            return sum + weight * environment(p, d);
        }
    }
    return sum + weight * environment(p, d);
}

void main() {
    GpuMaterial m = materials[draw.material.x];
    vec3 p = v_position;
    float side;
    vec3 n = face_viewer(surface_normal(v_normal, p), frame.viewer.xyz - p, side);
    vec3 n_mesh = n * side;
    vec3 albedo = m.lambertian.rgb;
    if ((m.flags.x & MATERIAL_TEXTURED) != 0u) {
        albedo *= texture(base_color, v_uv).rgb;
    }
    Bsdf bsdf = material_bsdf(m, albedo);
    vec3 wo = normalize(frame.viewer.xyz - p);
    vec3 radiance = material_emission(m, side) + direct_light(bsdf, p, n, n_mesh, wo);
    // The plane of the face this fragment lies on (derivatives: before any branch); only the
    // convex shortcut reads it.
    vec3 face = CONVEX_SHORTCUT ? cross(dFdx(p), dFdy(p)) : vec3(0.0);
    BsdfOriented o;
    if (bsdf_orient(bsdf, wo, n_mesh, n_mesh, o)) {
        vec3 c[4];
        bsdf_lobe_reflectances(bsdf, o, c);
        vec3 wi;
        float eta;
        if (any(greaterThan(c[LOBE_MIRROR], vec3(0.0)))
            && bsdf_sample_direction(bsdf, LOBE_MIRROR, o, vec2(0.0), wi, eta)) {
            radiance += c[LOBE_MIRROR] * follow(bsdf, p, wi, face);
        }
        if (any(greaterThan(c[LOBE_REFRACTION], vec3(0.0)))
            && bsdf_sample_direction(bsdf, LOBE_REFRACTION, o, vec2(0.0), wi, eta)) {
            radiance += c[LOBE_REFRACTION] * follow(bsdf, p, wi, face);
        }
    }
    out_radiance = vec4(max(radiance, vec3(0.0)), 1.0);
}
