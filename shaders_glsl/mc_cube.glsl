//! mc_cube.glsl — one cube of a block, for mc_count and mc_emit: its local corner and inside mask, and the
//! crossed edges it owns (those starting at its lower corner: a cube numbers the vertices of its own edges).
//! The table buffer (src/compute/mc.rs `table_words`): 12 packed edges (corner a | corner b << 4 | axis << 8),
//! then 256 triangle counts, then per case MC_MAX_TRIS × 3 edge indices.
#define MC_COUNTS 12u
#define MC_EDGES (12u + 256u)

// Cube `id` (block-major, then x fastest within the block): its lower corner `l` (local, 1 … MC_BLOCK) and its
// mask (bit m = corner m inside); 0 for cubes past the lattice (the CPU skips them too).
uint cube_mask(uint id, out uvec3 l) {
    const uint per = MC_BLOCK * MC_BLOCK * MC_BLOCK;
    uint b = id / per, k = id % per;
    l = uvec3(k % MC_BLOCK, (k / MC_BLOCK) % MC_BLOCK, k / (MC_BLOCK * MC_BLOCK)) + 1u;
    ivec3 g = blocks[b].xyz + ivec3(l);
    if (any(greaterThan(g, pc.ldims.xyz - 2))) return 0u;
    uint mask = 0u;
    for (uint m = 0u; m < 8u; ++m) {
        uvec3 d = uvec3(m & 1u, (m >> 1) & 1u, (m >> 2) & 1u);
        if (field[b * MC_NC + corner_index(l + d)] >= pc.field.z) mask |= 1u << m;
    }
    return mask;
}

// The crossed edges a cube with inside mask `mask` owns: bit a set when its edge along axis a (from corner 0 to
// corner 1, 2 or 4) is crossed. Its vertices are numbered in axis order.
uint owned_edges(uint mask) {
    uint c0 = mask & 1u;
    return (c0 ^ ((mask >> 1) & 1u)) | (c0 ^ ((mask >> 2) & 1u)) << 1 | (c0 ^ ((mask >> 4) & 1u)) << 2;
}
