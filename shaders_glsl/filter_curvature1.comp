#version 460
//! filter_curvature1 — curvature flow of the `filter` pass, ONE iteration per dispatch, straight from the
//! image (no shared memory). Same math as filter_curvature.comp (see curvature.glsl); the variant measured
//! against it by `meniscus bench`, and the faster one on lavapipe.
//! In: depth (r32f). Out: smoothed depth (r32f).
#include "common.glsl"
#include "curvature.glsl"
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
layout(set = 0, binding = 1, r32f) uniform readonly image2D src;
layout(set = 0, binding = 2, r32f) uniform writeonly image2D dst;
layout(push_constant) uniform Push {
    int iters;          // unused (1)
    int first_iter;     // global index of this iteration
    int it_max;
    float dt;
    float world_radius;
    float kappa;
    float edge;
} pc;

ivec2 g_size;

float nb(ivec2 q, float z) {
    if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, g_size))) return z;
    float v = imageLoad(src, q).x;
    return (is_fluid(v) && abs(v - z) < pc.edge) ? v : z;
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    g_size = imageSize(src);
    if (any(greaterThanEqual(p, g_size))) return;
    float z = imageLoad(src, p).x;
    float F = focal_for(float(g_size.y));
    int its = min(pc.it_max, int(F * pc.world_radius / max(z, 1e-6)));
    if (!is_fluid(z) || pc.first_iter >= its) {
        imageStore(dst, p, vec4(z));
        return;
    }
    float n0 = nb(p + ivec2(-1, -1), z), n1 = nb(p + ivec2(0, -1), z), n2 = nb(p + ivec2(1, -1), z);
    float n3 = nb(p + ivec2(-1, 0), z), n5 = nb(p + ivec2(1, 0), z);
    float n6 = nb(p + ivec2(-1, 1), z), n7 = nb(p + ivec2(0, 1), z), n8 = nb(p + ivec2(1, 1), z);
    imageStore(dst, p, vec4(curvature_step(z, n0, n1, n2, n3, n5, n6, n7, n8, F, pc.dt, pc.kappa)));
}
