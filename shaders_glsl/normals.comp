#version 460
//! normals — view-space normals from the smoothed depth (Moritz eq. 3.12: cross product of the view-position
//! derivatives). Along each axis: the central difference where both neighbours lie on the same surface, else
//! the one-sided difference with the SMALLER depth change (NVIDIA patent US 8,947,430), so silhouettes and
//! occlusion edges do not bend the normal. Normals face the camera.
//! NORMALS_DETAIL (the variant run while an effect gives a detail height field: the `noise` effect's N, NVIDIA
//! patent US 8,947,430): the height field h (radii, fixed point: DETAIL_UNITS per radius, signed) on
//! the fluid becomes small waves — its screen-space partial derivatives, turned into slopes per world unit at the
//! pixel's depth (× strength · r · F / d), are subtracted from the normal: n' = normalize(n − (∂h/∂X, ∂h/∂Y, 0)),
//! view space. Along each axis the derivative is the central difference where both neighbours are on the same
//! surface (depth jump under `edge`), else one-sided, else 0. Here rather than in a pass of the effect's own: the
//! depths it compares are the ones this pass loads anyway, and the normal is written once (a separate pass cost
//! lavapipe 3 ms of the wave frame at 480×270 and 7–11 ms at 960×540; docs/gpu-frame.md).
//! In: smoothed depth (r32f); with NORMALS_DETAIL the height field (r32ui, read at the pixel: level 0 of the
//! noise's atlas). Out: normals (r32ui, octahedral 2×snorm16; 0 where there is no fluid).
#include "common.glsl"
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
layout(set = 0, binding = 1, r32f) uniform readonly image2D depth;
layout(set = 0, binding = 2, r32ui) uniform writeonly uimage2D normals;
#ifdef NORMALS_DETAIL
layout(set = 0, binding = 3, r32ui) uniform readonly uimage2D detail;
#endif
layout(push_constant) uniform Push {
    float edge;     // world depth jump that marks a discontinuity
    float strength; // scale of the detail's slopes (NORMALS_DETAIL)
} pc;

ivec2 g_size;
float g_F;

float load(ivec2 q) {
    if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, g_size))) return INF;
    return imageLoad(depth, q).x;
}

vec3 pos(ivec2 q, float d) { return d * pixel_dir(vec2(q), vec2(g_size), g_F); }

/// Derivative of the view position along `step` at p (depth d, position P; df, db: the depths ahead, behind).
vec3 derivative(ivec2 p, float d, vec3 P, ivec2 step, float df, float db) {
    bool okf = is_fluid(df), okb = is_fluid(db);
    float ef = abs(df - d), eb = abs(d - db);
    if (okf && okb && ef < pc.edge && eb < pc.edge) return 0.5 * (pos(p + step, df) - pos(p - step, db));
    if (okf && (!okb || ef <= eb)) return pos(p + step, df) - P;
    if (okb) return P - pos(p - step, db);
    return pos(p + step, d) - P; // isolated pixel: a plane facing the camera
}

#ifdef NORMALS_DETAIL
/// The height field at q (radii).
float height(ivec2 q) { return float(int(imageLoad(detail, q).x)) * (1.0 / float(DETAIL_UNITS)); }

/// dh per pixel along `step` at p (height h0): neighbours on the same surface when their depths (df ahead, db
/// behind) are fluid within `edge` of d. Each neighbour's height is loaded once, whichever difference uses it
/// (clamped to the image: a neighbour off it is never used): lavapipe runs every branch as masked SIMD lanes, so
/// a load in each branch was paid in each.
float slope(ivec2 p, float d, float h0, ivec2 step, float df, float db) {
    bool f = is_fluid(df) && abs(df - d) < pc.edge, b = is_fluid(db) && abs(db - d) < pc.edge;
    float hf = height(clamp(p + step, ivec2(0), g_size - 1)), hb = height(clamp(p - step, ivec2(0), g_size - 1));
    return f && b ? 0.5 * (hf - hb) : f ? hf - h0 : b ? h0 - hb : 0.0;
}
#endif

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
    ivec2 X = ivec2(1, 0), Y = ivec2(0, 1); // rows grow downwards
    float xf = load(p + X), xb = load(p - X), yf = load(p + Y), yb = load(p - Y);
    vec3 dx = derivative(p, d, P, X, xf, xb);
    vec3 dy = derivative(p, d, P, Y, yf, yb);
    vec3 n = normalize(cross(dy, dx));
    if (dot(n, P) > 0.0) n = -n;
#ifdef NORMALS_DETAIL
    // World units of height per pixel step, per world unit across: strength · r · F / d.
    float h0 = height(p);
    float k = pc.strength * frame.fluid.x * g_F / d;
    float gx = slope(p, d, h0, X, xf, xb) * k;
    float gy = -slope(p, d, h0, Y, yf, yb) * k; // image y grows downwards, view Y upwards
    n = normalize(n - vec3(gx, gy, 0.0));
#endif
    imageStore(normals, p, uvec4(pack_normal(n)));
}
