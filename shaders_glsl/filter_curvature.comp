#version 460
//! filter_curvature — curvature flow of the `filter` pass (van der Laan, Green & Sainz 2009; Moritz §3.3.3):
//!   d ← d − Δt·H,  H = [C_y(½ z_x D_x − z_xx D) + C_x(½ z_y D_y − z_yy D)] / (2 D^{3/2}),
//!   D = C_y² z_x² + C_x² z_y² + C_x² C_y² (z+κ)²,   C = 1/F (square pixels).
//! (The papers iterate z ← z + Δt·H on negative view z; with positive depth d the sign flips.)
//! κ stabiliser near the camera (Moritz: (z−κ) in the last term of D). Depth-adaptive iteration count
//! (Bagar 2010; Moritz eq. 3.8): pixel p takes part in iteration i only while i < F·ρ/d(p) and i < it_max.
//! Neighbours that are background or across a depth jump are replaced by the centre (zero derivative), so
//! silhouette pixels never bleed into the background and separate surfaces do not merge. A per-step
//! stability clamp keeps the explicit scheme stable at any resolution.
//! SEVERAL ITERATIONS PER DISPATCH: a 16×16 tile plus a halo of K pixels lives in shared memory; each of the
//! K iterations shrinks the valid region by one pixel; only the centre is written back.
//! In: depth (r32f). Out: smoothed depth (r32f).
#include "common.glsl"
#include "curvature.glsl"
#define LOCAL CURVATURE_LOCAL
#define MAX_K 4
#define TILE (LOCAL + 2 * MAX_K)
layout(local_size_x = LOCAL, local_size_y = LOCAL) in;
layout(set = 0, binding = 1, r32f) uniform readonly image2D src;
layout(set = 0, binding = 2, r32f) uniform writeonly image2D dst;
layout(push_constant) uniform Push {
    int iters;          // K iterations in this dispatch (≤ MAX_K)
    int first_iter;     // global index of the first
    int it_max;         // cap of the adaptive count
    float dt;           // Δt
    float world_radius; // ρ: iterations = F·ρ/d
    float kappa;        // κ (world)
    float edge;         // depth jump (world) that separates surfaces
} pc;

shared float tile[2][TILE * TILE];

/// A neighbour's depth, or the centre's when it is background or across a depth jump.
float nb(int cur, int x, int y, int T, float z) {
    float v = tile[cur][y * T + x];
    return (is_fluid(v) && abs(v - z) < pc.edge) ? v : z;
}

void main() {
    ivec2 size = imageSize(src);
    int K = clamp(pc.iters, 1, MAX_K);
    int T = LOCAL + 2 * K;
    ivec2 origin = ivec2(gl_WorkGroupID.xy) * LOCAL - K;
    uint lid = gl_LocalInvocationIndex;
    for (uint i = lid; i < uint(T * T); i += LOCAL * LOCAL) {
        ivec2 q = origin + ivec2(int(i) % T, int(i) / T);
        float v = INF;
        if (all(greaterThanEqual(q, ivec2(0))) && all(lessThan(q, size))) v = imageLoad(src, q).x;
        tile[0][i] = v;
    }
    barrier();
    float F = focal_for(float(size.y));
    int cur = 0;
    for (int k = 0; k < K; ++k) {
        int iter = pc.first_iter + k;
        for (uint i = lid; i < uint(T * T); i += LOCAL * LOCAL) {
            int x = int(i) % T, y = int(i) / T;
            float z = tile[cur][i];
            // Cells outside the shrinking valid region, background, and finished pixels keep their value.
            bool inner = x > k && y > k && x < T - 1 - k && y < T - 1 - k;
            int its = min(pc.it_max, int(F * pc.world_radius / max(z, 1e-6)));
            if (!inner || !is_fluid(z) || iter >= its) {
                tile[1 - cur][i] = z;
                continue;
            }
            // 3×3 neighbourhood without a local array (arrays indexed in loops spill on CPU drivers).
            float n0 = nb(cur, x - 1, y - 1, T, z), n1 = nb(cur, x, y - 1, T, z), n2 = nb(cur, x + 1, y - 1, T, z);
            float n3 = nb(cur, x - 1, y, T, z), n5 = nb(cur, x + 1, y, T, z);
            float n6 = nb(cur, x - 1, y + 1, T, z), n7 = nb(cur, x, y + 1, T, z), n8 = nb(cur, x + 1, y + 1, T, z);
            tile[1 - cur][i] = curvature_step(z, n0, n1, n2, n3, n5, n6, n7, n8, F, pc.dt, pc.kappa);
        }
        barrier();
        cur = 1 - cur;
    }
    ivec2 l = ivec2(gl_LocalInvocationID.xy);
    ivec2 p = origin + K + l;
    if (all(lessThan(p, size))) imageStore(dst, p, vec4(tile[cur][(l.y + K) * T + (l.x + K)]));
}
