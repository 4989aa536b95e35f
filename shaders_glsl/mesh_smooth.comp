#version 460
//! mesh_smooth — Laplacian smoothing of a triangle mesh with feature weights and its area-weighted vertex
//! normals on the GPU: the finishing splashsurf's users apply (`[mesh] smoothing_iters`), the GPU form of
//! src/field/smooth.rs (its CPU reference, which the tests hold this to). Variants, in the order they run:
//! MESH_SMOOTH_COUNT — per triangle: each corner's vertex counts one more incident triangle (atomic).
//!     In: triangles (0). Out: counts (1, zeroed by the host).
//!     (The counts' exclusive prefix sum, the `grid` pass's scan, gives each vertex its run: starts.)
//! MESH_SMOOTH_FILL — per triangle: each corner's vertex takes the next slot of its run (atomic) for the
//!     triangle's index, and the two slots 2·(start + slot) … + 1 of the neighbour runs for its other corners.
//!     In: triangles (0), starts (1). In/out: fill (2, zeroed). Out: triangle runs (3), neighbour runs (4).
//! MESH_SMOOTH_SORT — per vertex: its triangle run sorted ascending (the CPU adds normals in triangle order),
//!     its neighbour run sorted and deduplicated in place (`vertex_neighbours`' sorted, unique list).
//!     In: starts (0), counts (1). In/out: triangle runs (2), neighbour runs (3). Out: the neighbours' (first,
//!     count) per vertex (4).
//! (plain) — one Jacobi iteration: v_i ← (1 − w_i) v_i + w_i · mean of its neighbours (the previous positions,
//!     summed in the neighbours' order, as the CPU folds them). In: positions (0), the neighbours' (first,
//!     count) (1), neighbour runs (2), weights (3). Out: positions (4).
//! MESH_SMOOTH_NORMALS — n_i = normalize(Σ over its triangles, ascending, of (b − a) × (c − a)), zero where that
//!     sum is. In: positions (0), starts (1), counts (2), triangle runs (3), triangles (4). Out: normals (5).
//! Positions and normals are packed float triples; sums are `precise` (no contracted multiply-adds), so on a
//! device that rounds as the CPU does the result is the CPU's bit for bit (lavapipe: it is).
//! *_LIVE (the live mesh surface, src/surface/mesh/live.rs): the same passes on the mesh the frame extracted, its
//! triangle and vertex counts read from the device (LiveN, the last binding; `n.x` is then the buffers' capacity
//! and `n.y` which count: 0 triangles, 1 vertices), the weights' 1/n_j the w of the renderer's weighted points.
#if defined(MESH_SMOOTH_WEIGHTS_LIVE)
#define MESH_SMOOTH_WEIGHTS
#define MESH_SMOOTH_LIVE
#elif defined(MESH_SMOOTH_COUNT_LIVE)
#define MESH_SMOOTH_COUNT
#define MESH_SMOOTH_LIVE
#elif defined(MESH_SMOOTH_FILL_LIVE)
#define MESH_SMOOTH_FILL
#define MESH_SMOOTH_LIVE
#elif defined(MESH_SMOOTH_SORT_LIVE)
#define MESH_SMOOTH_SORT
#define MESH_SMOOTH_LIVE
#endif
#ifdef MESH_SMOOTH_LIVE
#define N min(pc.n.x, live_n[pc.n.y])
#define LIVE_N(b) layout(std430, set = 0, binding = b) readonly buffer LiveN { uint live_n[4]; };
#else
#define N pc.n.x
#define LIVE_N(b)
#endif
layout(local_size_x = LOCAL_1D) in;
layout(push_constant) uniform SmoothPush {
    uvec4 n;      // x: vertices, or triangles (COUNT, FILL), or particles (NEIGHBOURS)
    vec4 grid;    // the particles' grid: origin xyz, cell side w (NEIGHBOURS, WEIGHTS)
    uvec4 gdims;  // cells per axis
    vec4 field;   // x: support h, y: the neighbour count of full weight (splashsurf's 13)
} pc;

uint flat_id() { return gl_GlobalInvocationID.x + gl_NumWorkGroups.x * gl_WorkGroupSize.x * gl_GlobalInvocationID.y; }

#if defined(MESH_SMOOTH_NEIGHBOURS) || defined(MESH_SMOOTH_WEIGHTS)
layout(std430, set = 0, binding = 0) readonly buffer Points { vec4 pts[]; };
layout(std430, set = 0, binding = 1) readonly buffer Cells { uvec2 cells[]; };
// The points of the 27 cells around x's cell, in the CPU grid's order (z, y, then one contiguous row of x).
#define FOR_NEAR(x, VISIT)                                                                       \
    {                                                                                            \
        ivec3 gd_ = ivec3(pc.gdims.xyz);                                                         \
        ivec3 cc_ = ivec3(floor(((x) - pc.grid.xyz) / pc.grid.w));                              \
        int x0_ = max(cc_.x - 1, 0), x1_ = min(cc_.x + 1, gd_.x - 1);                            \
        for (int z_ = max(cc_.z - 1, 0); z_ <= min(cc_.z + 1, gd_.z - 1); ++z_)                  \
            for (int y_ = max(cc_.y - 1, 0); y_ <= min(cc_.y + 1, gd_.y - 1) && x0_ <= x1_; ++y_) { \
                int row_ = gd_.x * (y_ + gd_.y * z_);                                            \
                uint first_ = cells[x0_ + row_].x;                                               \
                uvec2 last_ = cells[x1_ + row_];                                                 \
                for (uint j_ = first_; j_ < last_.x + last_.y; ++j_) VISIT(j_)                   \
            }                                                                                    \
    }
#endif

#if defined(MESH_SMOOTH_NEIGHBOURS)
//! MESH_SMOOTH_NEIGHBOURS — per particle j (sorted): c_j = Σ_{k ≠ j} max(0, 1 − |x_j − x_k|²/h²)
//!     (`IsoGrid::neighbour_weights`). In: points (0), cells (1). Out: c (2).
layout(std430, set = 0, binding = 2) writeonly buffer Counts { float counts[]; };
void main() {
    uint i = flat_id();
    if (i >= pc.n.x) return;
    vec3 x = pts[i].xyz;
    float h2 = pc.field.x * pc.field.x;
    precise float c = 0.0;
#define VISIT_C(j)                                                                               \
    if (j != i) {                                                                                \
        vec3 d = x - pts[j].xyz;                                                                 \
        c += max(1.0 - dot(d, d) / h2, 0.0);                                                     \
    }
    FOR_NEAR(x, VISIT_C)
    counts[i] = c;
}
#elif defined(MESH_SMOOTH_WEIGHTS)
//! MESH_SMOOTH_WEIGHTS — per vertex: its feature weight, the particles' c_j interpolated (Shepard, weights
//!     W(d/h)/n_j), over `normalization`, clamped, through 6t⁵ − 15t⁴ + 10t³ (`feature_weights`). In: points
//!     (0), cells (1), 1/n_j (2), c (3), positions (4). Out: weights (5).
layout(std430, set = 0, binding = 2) readonly buffer InvN { float inv_n[]; };
layout(std430, set = 0, binding = 3) readonly buffer Counts { float counts[]; };
layout(std430, set = 0, binding = 4) readonly buffer Pos { float pos[]; };
layout(std430, set = 0, binding = 5) writeonly buffer Weights { float weights[]; };
LIVE_N(6)
#ifdef MESH_SMOOTH_LIVE
#define INV_N(j) inv_n[4u * (j) + 3u]
#else
#define INV_N(j) inv_n[j]
#endif
float kernel(float q) {
    if (q <= 0.5) return 1.0 - 6.0 * q * q + 6.0 * q * q * q;
    float a = 1.0 - q;
    return q < 1.0 ? 2.0 * a * a * a : 0.0;
}
void main() {
    uint i = flat_id();
    if (i >= N) return;
    vec3 x = vec3(pos[3u * i], pos[3u * i + 1u], pos[3u * i + 2u]);
    precise float num = 0.0, den = 0.0;
#define VISIT_W(j)                                                                               \
    {                                                                                            \
        float w_ = kernel(distance(x, pts[j].xyz) / pc.field.x) * INV_N(j);                      \
        num += w_ * counts[j];                                                                   \
        den += w_;                                                                               \
    }
    FOR_NEAR(x, VISIT_W)
    float c = den > 0.0 ? num / den : 0.0;
    float t = clamp(c / max(pc.field.y, 1e-6), 0.0, 1.0);
    weights[i] = t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
}
#elif defined(MESH_SMOOTH_COUNT)
layout(std430, set = 0, binding = 0) readonly buffer Tris { uint tris[]; };
layout(std430, set = 0, binding = 1) buffer Counts { uint counts[]; };
LIVE_N(2)
void main() {
    uint t = flat_id();
    if (t >= N) return;
    for (uint k = 0u; k < 3u; ++k) atomicAdd(counts[tris[3u * t + k]], 1u);
}
#elif defined(MESH_SMOOTH_FILL)
layout(std430, set = 0, binding = 0) readonly buffer Tris { uint tris[]; };
layout(std430, set = 0, binding = 1) readonly buffer Starts { uint starts[]; };
layout(std430, set = 0, binding = 2) buffer Fill { uint fill[]; };
layout(std430, set = 0, binding = 3) writeonly buffer TriRuns { uint tri_runs[]; };
layout(std430, set = 0, binding = 4) writeonly buffer NbrRuns { uint nbr_runs[]; };
LIVE_N(5)
void main() {
    uint t = flat_id();
    if (t >= N) return;
    for (uint k = 0u; k < 3u; ++k) {
        uint v = tris[3u * t + k];
        uint at = starts[v] + atomicAdd(fill[v], 1u);
        tri_runs[at] = t;
        nbr_runs[2u * at] = tris[3u * t + (k + 1u) % 3u];
        nbr_runs[2u * at + 1u] = tris[3u * t + (k + 2u) % 3u];
    }
}
#elif defined(MESH_SMOOTH_SORT)
layout(std430, set = 0, binding = 0) readonly buffer Starts { uint starts[]; };
layout(std430, set = 0, binding = 1) readonly buffer Counts { uint counts[]; };
layout(std430, set = 0, binding = 2) buffer TriRuns { uint tri_runs[]; };
layout(std430, set = 0, binding = 3) buffer NbrRuns { uint nbr_runs[]; };
layout(std430, set = 0, binding = 4) writeonly buffer Ranges { uvec2 ranges[]; };
LIVE_N(5)
void main() {
    uint v = flat_id();
    if (v >= N) return;
    uint s = starts[v], c = counts[v];
    // Insertion sorts: a vertex of a marching-cubes mesh has a handful of triangles.
    for (uint i = 1u; i < c; ++i) {
        uint x = tri_runs[s + i], j = i;
        for (; j > 0u && tri_runs[s + j - 1u] > x; --j) tri_runs[s + j] = tri_runs[s + j - 1u];
        tri_runs[s + j] = x;
    }
    uint b = 2u * s, m = 2u * c;
    for (uint i = 1u; i < m; ++i) {
        uint x = nbr_runs[b + i], j = i;
        for (; j > 0u && nbr_runs[b + j - 1u] > x; --j) nbr_runs[b + j] = nbr_runs[b + j - 1u];
        nbr_runs[b + j] = x;
    }
    uint u = 0u;
    for (uint i = 0u; i < m; ++i) {
        uint x = nbr_runs[b + i];
        if (u == 0u || nbr_runs[b + u - 1u] != x) nbr_runs[b + u++] = x;
    }
    ranges[v] = uvec2(b, u);
}
#else
layout(std430, set = 0, binding = 0) readonly buffer Pos { float pos[]; };
vec3 at(uint i) { return vec3(pos[3u * i], pos[3u * i + 1u], pos[3u * i + 2u]); }
#if defined(MESH_SMOOTH_NORMALS)
layout(std430, set = 0, binding = 1) readonly buffer Starts { uint starts[]; };
layout(std430, set = 0, binding = 2) readonly buffer Counts { uint counts[]; };
layout(std430, set = 0, binding = 3) readonly buffer TriRuns { uint tri_runs[]; };
layout(std430, set = 0, binding = 4) readonly buffer Tris { uint tris[]; };
layout(std430, set = 0, binding = 5) writeonly buffer Out { float outv[]; };
#else
layout(std430, set = 0, binding = 1) readonly buffer Ranges { uvec2 ranges[]; };
layout(std430, set = 0, binding = 2) readonly buffer NbrRuns { uint nbr_runs[]; };
layout(std430, set = 0, binding = 3) readonly buffer Weights { float weights[]; };
layout(std430, set = 0, binding = 4) writeonly buffer Out { float outv[]; };
LIVE_N(5)
#endif

void main() {
    uint i = flat_id();
    if (i >= N) return;
#if defined(MESH_SMOOTH_NORMALS)
    vec3 acc = vec3(0.0);
    for (uint k = starts[i]; k < starts[i] + counts[i]; ++k) {
        uint t = tri_runs[k];
        vec3 a = at(tris[3u * t]), b = at(tris[3u * t + 1u]), c = at(tris[3u * t + 2u]);
        vec3 e1 = b - a, e2 = c - a;
        // glam's cross product, term for term.
        precise vec3 n = vec3(e1.y * e2.z - e2.y * e1.z, e1.z * e2.x - e2.z * e1.x, e1.x * e2.y - e2.x * e1.y);
        acc += n;
    }
    // glam's normalize_or_zero: times the reciprocal of the length where that is finite and positive.
    float rcp = 1.0 / length(acc);
    vec3 r = !isinf(rcp) && !isnan(rcp) && rcp > 0.0 ? acc * rcp : vec3(0.0);
#else
    vec3 v = at(i), r = v;
    uvec2 range = ranges[i];
    if (range.y > 0u) {
        precise vec3 sum = vec3(0.0);
        for (uint k = range.x; k < range.x + range.y; ++k) sum += at(nbr_runs[k]);
        precise vec3 mean = sum / float(range.y);
        float w = weights[i];
        precise vec3 moved = v * (1.0 - w) + mean * w;
        r = moved;
    }
#endif
    outv[3u * i] = r.x;
    outv[3u * i + 1u] = r.y;
    outv[3u * i + 2u] = r.z;
}
#endif
