#version 460
//! noise_scan — the tiled noise splat's list starts: an exclusive prefix sum of the n tile counts, by one work
//! group (each thread sums a run of consecutive tiles, the runs' sums are scanned in shared memory, then each
//! thread writes its run's starts); each tile's fill cursor starts at its start. Blelloch-style two-level scan.
//! The same scan numbers the tiles' chunks (NOISE_CHUNK sprites of a list each: noise_gather's work groups, so
//! no work group walks more than one chunk however many sprites pile up on one tile).
//! It also writes the indirect dispatches that follow: noise_fill, one thread per binned sprite, and
//! noise_gather, one work group per chunk — none when no sprite was binned (every sprite was small); and
//! noise_resolve's, none when the splat wrote level 0 alone (work[0], the coarsest level, is final after
//! noise_bin, which splats the small sprites; the gather writes the binned ones at their own levels, which bin
//! counted too).
//! The runs' sums are scanned within each subgroup (subgroupExclusiveAdd) and the subgroups' totals by one
//! thread: two barriers, where a Hillis–Steele scan of the 1024 runs took twenty (0.029 ms of the H100's 1080p
//! frame for 11 k tiles).
//! In/out: tiles ([0, n) counts → [n, 2n) starts, [2n, 3n) cursors, [3n, 4n) first chunks). In: work[6]
//! (sprites binned). Out: args.
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
layout(local_size_x = 1024) in;
layout(std430, set = 0, binding = 0) buffer Tiles { uint tiles[]; };
layout(std430, set = 0, binding = 1) readonly buffer Work { uint work[8]; };
// Three dispatches' work group counts: [0, 3) noise_fill, [3, 6) noise_gather, [8, 11) noise_resolve (none
// when the splat wrote level 0 alone: the normals and the composite then read the sums themselves).
layout(std430, set = 0, binding = 2) writeonly buffer Args { uint args[12]; };
#include "noise_push.glsl"

// Per subgroup: its runs' total, then the sum of the subgroups before it (subgroups of 4 lanes or more).
shared uvec2 s_part[256];

void main() {
    uint t = gl_LocalInvocationID.x;
    uint n = pc.tiles;
    uint binned = work[6];
    if (t == 0u) {
        args[0] = (binned + uint(LOCAL_1D) - 1u) / uint(LOCAL_1D);
        args[1] = 1u;
        args[2] = 1u;
        args[4] = 1u;
        args[5] = 1u;
        args[8] = work[0] > 0u ? pc.resolve.x : 0u;
        args[9] = pc.resolve.y;
        args[10] = 1u;
    }
    uint run = (n + 1023u) / 1024u;
    uint a = min(t * run, n), b = min(a + run, n);
    // (sprites, chunks) of the run.
    uvec2 sum = uvec2(0u);
    for (uint k = a; k < b; ++k) sum += uvec2(tiles[k], (tiles[k] + NOISE_CHUNK - 1u) / NOISE_CHUNK);
    uvec2 before = subgroupExclusiveAdd(sum);
    if (gl_SubgroupInvocationID == gl_SubgroupSize - 1u) s_part[gl_SubgroupID] = before + sum;
    barrier();
    if (t == 0u) {
        uvec2 total = uvec2(0u);
        for (uint g = 0u; g < gl_NumSubgroups; ++g) {
            uvec2 v = s_part[g];
            s_part[g] = total;
            total += v;
        }
        // The gather's work groups: every chunk of every tile.
        args[3] = binned > 0u ? total.y : 0u;
    }
    barrier();
    uvec2 start = s_part[gl_SubgroupID] + before;
    for (uint k = a; k < b; ++k) {
        uint c = tiles[k];
        tiles[n + k] = start.x;
        tiles[2u * n + k] = start.x;
        tiles[3u * n + k] = start.y;
        start += uvec2(c, (c + NOISE_CHUNK - 1u) / NOISE_CHUNK);
    }
}
