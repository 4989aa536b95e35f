#version 460
//! normals — view-space normals from the smoothed depth (Moritz eq. 3.12: cross product of the view-position
//! derivatives). Along each axis: the central difference where both neighbours lie on the same surface, else
//! the one-sided difference with the SMALLER depth change (NVIDIA patent US 8,947,430), so silhouettes and
//! occlusion edges do not bend the normal. Normals face the camera.
//! In: smoothed depth (r32f). Out: normals (r32ui, octahedral 2×snorm16; 0 where there is no fluid).
#include "common.glsl"
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
layout(set = 0, binding = 1, r32f) uniform readonly image2D depth;
layout(set = 0, binding = 2, r32ui) uniform writeonly uimage2D normals;
layout(push_constant) uniform Push { float edge; } pc; // world depth jump that marks a discontinuity

ivec2 g_size;
float g_F;

float load(ivec2 q) {
    if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, g_size))) return INF;
    return imageLoad(depth, q).x;
}

vec3 pos(ivec2 q, float d) { return d * pixel_dir(vec2(q), vec2(g_size), g_F); }

/// Derivative of the view position along `step` at p (depth d, position P).
vec3 derivative(ivec2 p, float d, vec3 P, ivec2 step) {
    float df = load(p + step), db = load(p - step);
    bool okf = is_fluid(df), okb = is_fluid(db);
    float ef = abs(df - d), eb = abs(d - db);
    if (okf && okb && ef < pc.edge && eb < pc.edge) return 0.5 * (pos(p + step, df) - pos(p - step, db));
    if (okf && (!okb || ef <= eb)) return pos(p + step, df) - P;
    if (okb) return P - pos(p - step, db);
    return pos(p + step, d) - P; // isolated pixel: a plane facing the camera
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    g_size = imageSize(depth);
    if (any(greaterThanEqual(p, g_size))) return;
    g_F = focal_for(float(g_size.y));
    float d = imageLoad(depth, p).x;
    if (!is_fluid(d)) {
        imageStore(normals, p, uvec4(0u));
        return;
    }
    vec3 P = pos(p, d);
    vec3 dx = derivative(p, d, P, ivec2(1, 0));
    vec3 dy = derivative(p, d, P, ivec2(0, 1)); // rows grow downwards
    vec3 n = normalize(cross(dy, dx));
    if (dot(n, P) > 0.0) n = -n;
    imageStore(normals, p, uvec4(pack_normal(n)));
}
