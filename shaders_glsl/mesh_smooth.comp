#version 460
//! mesh_smooth — Laplacian smoothing of a triangle mesh with feature weights and its area-weighted vertex
//! normals on the GPU: the finishing splashsurf's users apply (`[mesh] smoothing_iters`), the GPU form of
//! src/field/smooth.rs (its CPU reference, which the tests hold this to). The host gives each vertex its edge
//! neighbours (sorted, unique: `vertex_neighbours`) and its feature weight w_i (`feature_weights`), and each
//! vertex its incident triangles in ascending order.
//! (plain) — one Jacobi iteration: v_i ← (1 − w_i) v_i + w_i · mean of its neighbours (the previous positions,
//!     summed in the neighbours' order, as the CPU folds them). In: positions (0), offsets (1), neighbours (2),
//!     weights (3). Out: positions (4).
//! MESH_SMOOTH_NORMALS — n_i = normalize(Σ over its triangles, in ascending order, of (b − a) × (c − a)), zero
//!     where that sum is. In: positions (0), offsets (1), incident triangles (2), triangles (3). Out: normals (4).
//! Positions and normals are packed float triples.
layout(local_size_x = LOCAL_1D) in;
layout(push_constant) uniform SmoothPush {
    uint n;  // vertices
} pc;
layout(std430, set = 0, binding = 0) readonly buffer Pos { float pos[]; };
layout(std430, set = 0, binding = 1) readonly buffer Offsets { uint offsets[]; };
layout(std430, set = 0, binding = 2) readonly buffer Lists { uint lists[]; };
#if defined(MESH_SMOOTH_NORMALS)
layout(std430, set = 0, binding = 3) readonly buffer Tris { uint tris[]; };
#else
layout(std430, set = 0, binding = 3) readonly buffer Weights { float weights[]; };
#endif
layout(std430, set = 0, binding = 4) writeonly buffer Out { float outv[]; };

vec3 at(uint i) { return vec3(pos[3u * i], pos[3u * i + 1u], pos[3u * i + 2u]); }

void main() {
    uint i = gl_GlobalInvocationID.x + gl_NumWorkGroups.x * gl_WorkGroupSize.x * gl_GlobalInvocationID.y;
    if (i >= pc.n) return;
    uint first = offsets[i], last = offsets[i + 1u];
#if defined(MESH_SMOOTH_NORMALS)
    vec3 acc = vec3(0.0);
    for (uint k = first; k < last; ++k) {
        uint t = lists[k];
        vec3 a = at(tris[3u * t]), b = at(tris[3u * t + 1u]), c = at(tris[3u * t + 2u]);
        vec3 e1 = b - a, e2 = c - a;
        // glam's cross product, term for term (no contraction across the two products).
        precise vec3 n = vec3(e1.y * e2.z - e2.y * e1.z, e1.z * e2.x - e2.z * e1.x, e1.x * e2.y - e2.x * e1.y);
        acc += n;
    }
    // glam's normalize_or_zero: times the reciprocal of the length where that is finite and positive.
    float rcp = 1.0 / length(acc);
    vec3 r = !isinf(rcp) && !isnan(rcp) && rcp > 0.0 ? acc * rcp : vec3(0.0);
#else
    vec3 v = at(i), r = v;
    if (last > first) {
        precise vec3 sum = vec3(0.0);
        for (uint k = first; k < last; ++k) sum += at(lists[k]);
        precise vec3 mean = sum / float(last - first);
        float w = weights[i];
        precise vec3 moved = v * (1.0 - w) + mean * w;
        r = moved;
    }
#endif
    outv[3u * i] = r.x;
    outv[3u * i + 1u] = r.y;
    outv[3u * i + 2u] = r.z;
}
