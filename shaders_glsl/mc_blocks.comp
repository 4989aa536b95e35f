#version 460
//! mc_blocks — the `mc` pass's occupied blocks found on the device, for the live mesh surface
//! (src/surface/mesh/live.rs), where the particles never reach the host: the same blocks the CPU's
//! `occupied_blocks` lists (src/field/extract/blocks.rs), in the same key order, which mc_emit's binary search
//! needs. Three variants, in a frame's order:
//! * MC_BLOCKS_MARK: every particle marks the blocks of MC_BLOCK³ cubes its support reaches — its lattice cell
//!   ± the support in cubes, clipped to the lattice (dims − 2 cubes) — as one flag per block (key
//!   (x · nb.y + y) · nb.z + z). The grid pass's scan then numbers the marked blocks.
//! * MC_BLOCKS_LIST: every marked block writes its lower corner (one cube of margin below: block · MC_BLOCK − 1)
//!   at its number; the last block writes the count (at most the blocks buffer's capacity) and the capacities
//!   into `Live` (what mc_field, mc_count and mc_emit read instead of push constants), and the next stages'
//!   indirect dispatches: mc_field one work group per block, mc_count and mc_emit one thread per cube.
//! * MC_BLOCKS_ARGS: after mc_count and the scans of both counts (over every cube the buffers hold; the cubes
//!   past the blocks count zero), the totals: the draw's vertex count (3 per triangle, at most the capacity) and
//!   the work the host reads after the frame (blocks, triangles, vertices, whether a capacity was exceeded),
//!   and for the smoothing the counts (LiveN) and its per-vertex and per-triangle indirect dispatches.
//! In/out by variant: MARK points (xyz) → flags; LIST flags, numbers → blocks, Live, args; ARGS triangle counts
//! and starts, vertex counts and starts, Live → args, stats, LiveN.
#include "mc_common.glsl"
layout(local_size_x = LOCAL_1D) in;

// Push constants follow McPush (mc_common.glsl): lat = lattice origin and cube edge, ldims = corners per axis,
// gdims.xyz = blocks per axis, gdims.w = particles (MARK) or blocks (LIST), field.x = support in cubes (as
// float), field.yzw = the capacities (blocks, triangles, vertices; as uintBitsToFloat).

#if defined(MC_BLOCKS_MARK)
layout(std430, binding = 0) readonly buffer Points { vec4 pts[]; };
layout(std430, binding = 1) writeonly buffer Flags { uint flags[]; };

void main() {
    uint i = flat_group() * gl_WorkGroupSize.x + gl_LocalInvocationID.x;
    if (i >= pc.gdims.w) return;
    vec3 x = pts[i].xyz;
    if (any(isnan(x)) || any(isinf(x))) return;
    int reach = int(pc.field.x);
    ivec3 c = ivec3(floor((x - pc.lat.xyz) / pc.lat.w));
    ivec3 b0 = max(c - reach, ivec3(0)) / int(MC_BLOCK);
    ivec3 b1 = min(c + reach, pc.ldims.xyz - 2) / int(MC_BLOCK);
    ivec3 nb = ivec3(pc.gdims.xyz);
    b1 = min(b1, nb - 1);
    for (int bx = b0.x; bx <= b1.x; ++bx)
        for (int by = b0.y; by <= b1.y; ++by)
            for (int bz = b0.z; bz <= b1.z; ++bz) flags[(bx * nb.y + by) * nb.z + bz] = 1u;
}

#elif defined(MC_BLOCKS_LIST)
layout(std430, binding = 0) readonly buffer Flags { uint flags[]; };
layout(std430, binding = 1) readonly buffer Numbers { uint numbers[]; };
layout(std430, binding = 2) writeonly buffer Blocks { ivec4 blocks[]; };
layout(std430, binding = 3) writeonly buffer LiveOut { uvec4 live_out; };
layout(std430, binding = 4) writeonly buffer Args { uint args[]; };

// A VkDispatchIndirectCommand of n work groups over two axes (compute::groups_2d's split).
void groups_2d(uint at, uint n) {
    uint x = clamp(n, 1u, 32768u);
    args[at] = x;
    args[at + 1u] = max((n + x - 1u) / x, 1u);
    args[at + 2u] = 1u;
}

void main() {
    uint k = flat_group() * gl_WorkGroupSize.x + gl_LocalInvocationID.x;
    uint all_blocks = pc.gdims.w, cap = floatBitsToUint(pc.field.y);
    if (k >= all_blocks) return;
    uint at = numbers[k];
    if (flags[k] != 0u && at < cap) {
        ivec3 nb = ivec3(pc.gdims.xyz);
        ivec3 b = ivec3(int(k) / (nb.y * nb.z), (int(k) / nb.z) % nb.y, int(k) % nb.z);
        blocks[at] = ivec4(b * int(MC_BLOCK) - 1, 0);
    }
    if (k == all_blocks - 1u) {
        uint n = at + flags[k];
        uint kept = min(n, cap);
        live_out = uvec4(kept, floatBitsToUint(pc.field.z), floatBitsToUint(pc.field.w), n);
        groups_2d(0u, kept);
        groups_2d(4u, (kept * MC_BLOCK * MC_BLOCK * MC_BLOCK + LOCAL_1D - 1u) / LOCAL_1D);
    }
}

#elif defined(MC_BLOCKS_ARGS)
layout(std430, binding = 0) readonly buffer Counts { uint counts[]; };
layout(std430, binding = 1) readonly buffer Start { uint start[]; };
layout(std430, binding = 2) readonly buffer VCounts { uint vcounts[]; };
layout(std430, binding = 3) readonly buffer VStart { uint vstart[]; };
layout(std430, binding = 4) readonly buffer LiveIn { uvec4 live_in; };
layout(std430, binding = 5) writeonly buffer Args { uint args[]; };
layout(std430, binding = 6) writeonly buffer Stats { uint stats[]; };
layout(std430, binding = 7) writeonly buffer LiveN { uvec4 live_n; };

// A VkDispatchIndirectCommand of n threads of LOCAL_1D (compute::groups_2d's split, as flat ids count them).
void threads_2d(uint at, uint n) {
    uint g = (n + LOCAL_1D - 1u) / LOCAL_1D;
    uint x = clamp(g, 1u, 32768u);
    args[at] = x;
    args[at + 1u] = max((g + x - 1u) / x, 1u);
    args[at + 2u] = 1u;
}

void main() {
    if (gl_GlobalInvocationID.x != 0u) return;
    uint last = pc.gdims.w - 1u;
    uint tris = start[last] + counts[last], verts = vstart[last] + vcounts[last];
    uint t = min(tris, live_in.y), v = min(verts, live_in.z);
    // VkDrawIndirectCommand: vertices, instances, first vertex, first instance.
    args[8] = 3u * t;
    args[9] = 1u;
    args[10] = 0u;
    args[11] = 0u;
    // The smoothing's dispatches (mesh_smooth.comp's LIVE variants): per vertex, per triangle; their counts.
    threads_2d(12u, v);
    threads_2d(16u, t);
    live_n = uvec4(t, v, 0u, 0u);
    bool over = live_in.w > live_in.x || tris > live_in.y || verts > live_in.z;
    stats[0] = live_in.w;
    stats[1] = tris;
    stats[2] = verts;
    stats[3] = over ? 1u : 0u;
}
#endif
