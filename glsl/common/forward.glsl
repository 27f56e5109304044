// Helpers of the forward-shaded raster passes (environment map, translucent surfaces).
#ifndef FORWARD_GLSL
#define FORWARD_GLSL

// The unit shading normal of an interpolated `normal` at camera-relative `position`, with the
// face normal standing in for a degenerate one (opposite vertex normals). Fragment stage only.
vec3 surface_normal(vec3 normal, vec3 position) {
    float len = length(normal);
    if (!(len > 1e-6)) {
        normal = cross(dFdx(position), dFdy(position));
        len = length(normal);
    }
    return len > 0.0 ? normal / len : vec3(0.0, 1.0, 0.0);
}

// `n` turned towards `to_viewer`; `side` is +1 if that is the side the mesh's normals face,
// -1 if it was turned.
vec3 face_viewer(vec3 n, vec3 to_viewer, out float side) {
    side = dot(n, to_viewer) < 0.0 ? -1.0 : 1.0;
    return n * side;
}
#endif
