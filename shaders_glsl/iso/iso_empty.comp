#version 460
//! iso_empty — each iso-grid cell's empty distance E, for the casts' skip through empty space: the Chebyshev
//! distance, in cells, from the cell to the nearest cell holding a point, at most ISO_EMPTY_REACH + 1 (none
//! nearer). A point lies at least (E − 1) cells from any position in a cell of E ≥ 2 (and the 27 cells around
//! it are empty, so φ = 0 there): the march skips (E − 1) cells less the bound instead of the one cell the
//! 27-cell sum can see — the long rays from spray to the water behind it (iso_field.glsl, ISO_CELL_EMPTY).
//! A Chebyshev distance is separable: three dispatches, each a min over offsets k along one axis of
//! max(|k|, the distance so far). X: from the cell table's counts; Y; Z: writes the copy of the cell table the
//! casts read, E in the count's top ISO_EMPTY_BITS bits. Runs with the weights (`iso_density` pass), when the
//! particles change. CPU reference: UniformGrid::empty_distance in src/scene/grid.rs.
//! X in: cells (1, RG32UI); out: the distances so far (2, .x). Y in/out: the distances (1: .x read, .y
//! written). Z in: cells (1), the distances (2, .y); out: the casts' cell table (3).
#include "common.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(push_constant) uniform EmptyPush {
    uvec4 dims;  // xyz: cells per axis, w: cells
} pc;

#if defined(ISO_EMPTY_X)
layout(set = 0, binding = 1) uniform usamplerBuffer cells_t;
layout(std430, set = 0, binding = 2) writeonly buffer Dist { uvec2 dist[]; };
#elif defined(ISO_EMPTY_Y)
layout(std430, set = 0, binding = 1) buffer Dist { uvec2 dist[]; };
#else
layout(set = 0, binding = 1) uniform usamplerBuffer cells_t;
layout(std430, set = 0, binding = 2) readonly buffer Dist { uvec2 dist[]; };
layout(std430, set = 0, binding = 3) writeonly buffer Out { uvec2 cells_out[]; };
#endif

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.dims.w) return;
    ivec3 d = ivec3(pc.dims.xyz);
    ivec3 c = ivec3(int(i) % d.x, (int(i) / d.x) % d.y, int(i) / (d.x * d.y));
    const int K = int(ISO_EMPTY_REACH);
    uint e = uint(K + 1);
#if defined(ISO_EMPTY_X)
    for (int k = -K; k <= K; ++k) {
        if (c.x + k >= 0 && c.x + k < d.x && texelFetch(cells_t, int(i) + k).y > 0u) e = min(e, uint(abs(k)));
    }
    dist[i].x = e;
#elif defined(ISO_EMPTY_Y)
    for (int k = -K; k <= K; ++k) {
        if (c.y + k >= 0 && c.y + k < d.y) e = min(e, max(uint(abs(k)), dist[int(i) + k * d.x].x));
    }
    dist[i].y = e;
#else
    for (int k = -K; k <= K; ++k) {
        if (c.z + k >= 0 && c.z + k < d.z) e = min(e, max(uint(abs(k)), dist[int(i) + k * d.x * d.y].y));
    }
    uvec2 cell = texelFetch(cells_t, int(i)).xy;
    cells_out[i] = uvec2(cell.x, cell.y | (e << (32u - ISO_EMPTY_BITS)));
#endif
}
