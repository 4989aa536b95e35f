#version 460
//! mc_emit — the indexed mesh (last stage of the `mc` pass). Every cube writes
//! - the vertices of the crossed edges it owns (those starting at its lower corner, in axis order) at its place
//!   from the vertex prefix sum: each interpolated linearly on its edge, with the normal the CPU path gives it
//!   (the negative field gradient by central differences of the corner values, interpolated along the edge),
//!   and the edge (global start corner, axis) it lies on;
//! - its triangles at its place from the triangle prefix sum, each corner the index of its edge's vertex: the
//!   owning cube is this one, a neighbour in the block, or one in the next block along x, y and/or z (found by a
//!   binary search of the sorted blocks); the owner's crossed edges below the axis give the rank.
//! So the host copies a welded, indexed mesh: no sort, no weld. Every corner value is the same bit for bit in
//! every block that holds it (mc_field gathers by global corner), so the owner's edges read here are the ones
//! the owner counted. In: field, blocks, table, start, vertex start. Out: pos, nrm (3 floats per vertex),
//! tri (3 indices per triangle), edge (global start corner xyz, axis per vertex).
//! MC_LIVE (the live mesh surface): the block count and the capacities at binding 8 (instead of the edges); nothing is written past
//! a capacity (the host grows the buffers when mc_blocks' totals exceed them), and no edges (the draw needs none).
#define MC_LIVE_BINDING 8
#include "mc_common.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, binding = 0) readonly buffer Field { float field[]; };
layout(std430, binding = 1) readonly buffer Blocks { ivec4 blocks[]; };
layout(std430, binding = 2) readonly buffer Table { uint table[]; };
layout(std430, binding = 3) readonly buffer Start { uint start[]; };
layout(std430, binding = 4) readonly buffer VStart { uint vstart[]; };
layout(std430, binding = 5) writeonly buffer Pos { float pos[]; };
layout(std430, binding = 6) writeonly buffer Nrm { float nrm[]; };
layout(std430, binding = 7) writeonly buffer Tri { uint tri[]; };
#ifndef MC_LIVE
layout(std430, binding = 8) writeonly buffer Edge { ivec4 edge[]; };
#endif
#include "mc_cube.glsl"

const uint NONE = 0xffffffffu;

float at(uint b, uvec3 l) { return field[b * MC_NC + corner_index(l)]; }

vec3 grad(uint b, uvec3 l) {
    return vec3(at(b, l + uvec3(1, 0, 0)) - at(b, l - uvec3(1, 0, 0)), at(b, l + uvec3(0, 1, 0)) - at(b, l - uvec3(0, 1, 0)),
                at(b, l + uvec3(0, 0, 1)) - at(b, l - uvec3(0, 0, 1)));
}

uvec3 unit(uint axis) { return uvec3(axis == 0u ? 1u : 0u, axis == 1u ? 1u : 0u, axis == 2u ? 1u : 0u); }

// The block whose lower corner (with its margin) is c0, or NONE: blocks are sorted by (x, y, z).
uint find_block(ivec3 c0) {
    uint lo = 0u, hi = MC_BLOCKS;
    while (lo < hi) {
        uint mid = (lo + hi) / 2u;
        ivec3 m = blocks[mid].xyz;
        bool less = m.x < c0.x || (m.x == c0.x && (m.y < c0.y || (m.y == c0.y && m.z < c0.z)));
        if (less) lo = mid + 1u; else hi = mid;
    }
    return lo < MC_BLOCKS && blocks[lo].xyz == c0 ? lo : NONE;
}

// The vertex of the edge along `axis` from local corner `la` of block b (la in 1 … MC_BLOCK + 1).
uint vertex_of(uint b, uvec3 la, uint axis) {
    bool in0 = at(b, la) >= pc.field.z;
    uint rank = 0u;
    for (uint k = 0u; k < axis; ++k) {
        if (in0 != (at(b, la + unit(k)) >= pc.field.z)) ++rank;
    }
    uvec3 over = uvec3(greaterThan(la, uvec3(MC_BLOCK)));
    uint ob = b;
    if (any(greaterThan(over, uvec3(0u)))) {
        ob = find_block(blocks[b].xyz + ivec3(over) * int(MC_BLOCK));
        if (ob == NONE) return NONE;
        la -= over * MC_BLOCK;
    }
    uint oid = ob * (MC_BLOCK * MC_BLOCK * MC_BLOCK) + ((la.z - 1u) * MC_BLOCK + (la.y - 1u)) * MC_BLOCK + (la.x - 1u);
    return vstart[oid] + rank;
}

void main() {
    uint id = flat_group() * gl_WorkGroupSize.x + gl_LocalInvocationID.x;
    const uint per = MC_BLOCK * MC_BLOCK * MC_BLOCK;
    if (id >= MC_BLOCKS * per) return;
    uvec3 l;
    uint mask = cube_mask(id, l);
    if (mask == 0u || mask == 255u) return;
    uint b = id / per;
    ivec3 c0 = blocks[b].xyz;
    // The vertices of the cube's own crossed edges.
    uint owned = owned_edges(mask);
    uint v = vstart[id];
    for (uint axis = 0u; axis < 3u; ++axis) {
        if ((owned & (1u << axis)) == 0u) continue;
        uvec3 lb = l + unit(axis);
        float fa = at(b, l), fb = at(b, lb);
        float tt = clamp((pc.field.z - fa) / (fb - fa), 0.0, 1.0);
        vec3 p = pc.lat.xyz + vec3(c0 + ivec3(l)) * pc.lat.w;
        p[axis] += pc.lat.w * tt;
        vec3 g = -(grad(b, l) * (1.0 - tt) + grad(b, lb) * tt);
        float gl = length(g);
        vec3 n = gl > 0.0 && !isinf(gl) ? g / gl : vec3(0.0);
#ifdef MC_LIVE
        if (v < live_vert_cap) {
#endif
        for (uint k = 0u; k < 3u; ++k) {
            pos[3u * v + k] = p[k];
            nrm[3u * v + k] = n[k];
        }
#ifdef MC_LIVE
        }
#else
        edge[v] = ivec4(c0 + ivec3(l), int(axis));
#endif
        ++v;
    }
    // The triangles, by the vertices of their edges.
    uint n = table[MC_COUNTS + mask];
    uint o = start[id];
#ifdef MC_LIVE
    n = min(n, live_tri_cap - min(o, live_tri_cap));
#endif
    for (uint t = 0u; t < n; ++t) {
        for (uint k = 0u; k < 3u; ++k) {
            uint e = table[MC_EDGES + (mask * MC_MAX_TRIS + t) * 3u + k];
            uint ed = table[e];
            uint a = ed & 15u, axis = ed >> 8;
            uvec3 la = l + uvec3(a & 1u, (a >> 1) & 1u, (a >> 2) & 1u);
            tri[3u * (o + t) + k] = vertex_of(b, la, axis);
        }
    }
}
