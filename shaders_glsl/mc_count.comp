#version 460
//! mc_count — triangles per cube (second stage of the `mc` pass): each cube of each block (MC_BLOCK³ per block,
//! those past the lattice count 0) reads its 8 corners, forms the inside mask (field ≥ threshold) and looks up
//! how many triangles the case table gives it. An exclusive prefix sum of these counts (the `grid` pass's scan)
//! then gives every cube its place in the output. In: field, blocks, table. Out: counts (one per cube).
#include "mc_common.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, binding = 0) readonly buffer Field { float field[]; };
layout(std430, binding = 1) readonly buffer Blocks { ivec4 blocks[]; };
layout(std430, binding = 2) readonly buffer Table { uint table[]; };
layout(std430, binding = 3) writeonly buffer Counts { uint counts[]; };
#include "mc_cube.glsl"

void main() {
    uint id = flat_group() * gl_WorkGroupSize.x + gl_LocalInvocationID.x;
    const uint per = MC_BLOCK * MC_BLOCK * MC_BLOCK;
    if (id >= uint(pc.ldims.w) * per) return;
    uvec3 l;
    uint mask = cube_mask(id, l);
    counts[id] = mask == 0u || mask == 255u ? 0u : table[MC_COUNTS + mask];
}
