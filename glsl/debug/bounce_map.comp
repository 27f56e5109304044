#version 460
// Debug view: the first light view's bounce map (one record per light G-buffer texel),
// stretched over the display: each surviving photon's power on a log scale (Turbo, 4 decades
// below the view's brightest), absorbed photons and empty texels black. A bounce map split over
// buffers (src/passes/bounce_map.rs, Split) is shown by one dispatch per buffer: this one
// writes the pixels of records first_record .. first_record + records, which lie in the bound
// buffer, whose first record is record `base` of the map.
#include "shared.glsl"
#include "packing.glsl"
#include "debug.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba8) uniform writeonly image2D display;
layout(std430, set = 0, binding = 1) readonly buffer Views { BounceView views[]; };
layout(std430, set = 0, binding = 2) readonly buffer BounceMap {
    PackedBounceMapPhoton bounce_map[];
};

layout(push_constant) uniform Push {
    float inv_peak;  // 1 / the brightest record's luminance
    uint view;
    uint first_record;
    uint records;
    uint base;
    uint pad0;
    uint pad1;
    uint pad2;
} push;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(display);
    if (px.x >= size.x || px.y >= size.y) {
        return;
    }
    BounceView v = views[push.view];
    uvec2 extent = max(v.texels.xy, uvec2(1));
    uvec2 t = min(uvec2((vec2(px) + 0.5) * vec2(extent) / vec2(size)), extent - 1);
    uint record = v.texels.z + t.y * extent.x + t.x;
    if (record - push.first_record >= push.records) {
        return;  // in another buffer: another dispatch's pixel (unsigned: below wraps)
    }
    BounceMapPhoton p = bounce_map_photon_load(bounce_map[record - push.base]);
    float lum = luminance(p.power);
    vec3 c = lum > 0.0 ? turbo(log_scale(lum, push.inv_peak, 4.0)) : vec3(0.0);
    imageStore(display, px, vec4(c, 1.0));
}
