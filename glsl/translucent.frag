#version 460
// Translucent and mirror surfaces, fragment stage: forward shading over the opaque result.
//   non-delta lobes: shadowed direct light, as the direct pass would give them
//   mirror lobe:     the environment cube maps (direct + the photons' indirect light) in the
//                    reflected direction
//   refraction lobe: the environment cube maps in the refracted direction (Snell, eta of the
//                    side the viewer is on; total internal reflection reflects); a ray that
//                    enters an object leaves it again through its bounding sphere
// The lobe weights are the über-BSDF's own (bsdf_lobe_reflectances: Fresnel-weighted when the
// material asks for it), so what the eye sees matches what photons do at the surface.
// Lookups are projected onto the scene's bounding box from the cube's centre (parallax
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

// Radiance arriving at `p` along `t`, a direction refracted into a closed object: the ray
// leaves through the object's bounding sphere (exact for spheres, an approximation otherwise)
// and refracts out there; total internal reflection at the exit continues along the reflected
// direction from the exit point.
vec3 through_object(vec3 p, vec3 t, float ior) {
    vec3 c = vec3(draw.normal0.w, draw.normal1.w, draw.normal2.w);
    float r = uintBitsToFloat(draw.material.y);
    vec3 o = p - c;
    float b = dot(o, t);
    float disc = b * b - (dot(o, o) - r * r);
    if (!(r > 0.0) || !(disc >= 0.0)) {
        return environment(p, t);
    }
    vec3 exit = p + max(-b + sqrt(disc), 0.0) * t;
    vec3 n_out = normalize(exit - c);
    vec3 out_dir = refract(t, -n_out, ior);
    if (dot(out_dir, out_dir) == 0.0) {
        out_dir = reflect(t, -n_out);
    }
    return environment(exit, out_dir);
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
    BsdfOriented o;
    if (bsdf_orient(bsdf, wo, n_mesh, n_mesh, o)) {
        vec3 c[4];
        bsdf_lobe_reflectances(bsdf, o, c);
        vec3 wi;
        float eta;
        if (any(greaterThan(c[LOBE_MIRROR], vec3(0.0)))
            && bsdf_sample_direction(bsdf, LOBE_MIRROR, o, vec2(0.0), wi, eta)) {
            radiance += c[LOBE_MIRROR] * environment(p, wi);
        }
        if (any(greaterThan(c[LOBE_REFRACTION], vec3(0.0)))
            && bsdf_sample_direction(bsdf, LOBE_REFRACTION, o, vec2(0.0), wi, eta)) {
            // Entering (eta = ior > 1 seen from outside): leave through the far side too.
            bool entered = eta != 1.0 && dot(wi, n_mesh) < 0.0 && side > 0.0;
            radiance += c[LOBE_REFRACTION]
                * (entered ? through_object(p, wi, bsdf.ior) : environment(p, wi));
        }
    }
    out_radiance = vec4(max(radiance, vec3(0.0)), 1.0);
}
