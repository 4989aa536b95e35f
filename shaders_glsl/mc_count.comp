#version 460
//! mc_count — triangles and vertices per cube (second stage of the `mc` pass): each cube of each block
//! (MC_BLOCK³ per block, those past the lattice count 0) reads its 8 corners, forms the inside mask
//! (field ≥ threshold) and looks up how many triangles the case table gives it; and counts the crossed edges it
//! OWNS — the three that start at its lower corner (+x, +y, +z), so that every crossed edge of the lattice has
//! exactly one owner. Exclusive prefix sums of both counts (the `grid` pass's scan) then give every cube its place
//! in the triangle and the vertex output. In: field, blocks, table (MC_LIVE: the block count, binding 5). Out:
//! counts, vertex counts (one per cube).
#define MC_LIVE_BINDING 5
#include "mc_common.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, binding = 0) readonly buffer Field { float field[]; };
layout(std430, binding = 1) readonly buffer Blocks { ivec4 blocks[]; };
layout(std430, binding = 2) readonly buffer Table { uint table[]; };
layout(std430, binding = 3) writeonly buffer Counts { uint counts[]; };
layout(std430, binding = 4) writeonly buffer VCounts { uint vcounts[]; };
#include "mc_cube.glsl"

void main() {
    uint id = flat_group() * gl_WorkGroupSize.x + gl_LocalInvocationID.x;
    const uint per = MC_BLOCK * MC_BLOCK * MC_BLOCK;
    if (id >= MC_BLOCKS * per) return;
    uvec3 l;
    uint mask = cube_mask(id, l);
    bool crossing = mask != 0u && mask != 255u;
    counts[id] = crossing ? table[MC_COUNTS + mask] : 0u;
    vcounts[id] = crossing ? bitCount(owned_edges(mask)) : 0u;
}
