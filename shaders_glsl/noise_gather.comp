#version 460
//! noise_gather — the tiled noise splat's sums (GPUs; NVIDIA patent US 8,947,430, eq. 15–17): one
//! work group per chunk (NOISE_CHUNK sprites of one tile's list, numbered by noise_scan) of a tile of the
//! accumulator atlas (NOISE_TILE² texels of one level); its threads load the chunk's sprites into shared memory
//! and each thread adds every sprite's term at its own texel (noise_splat.glsl's `noise_term`, the same
//! fixed-point terms noise.comp adds with atomics), reading its depth once, and adds its sum to its texel once
//! (to the small sprites' terms noise_bin added and the tile's other chunks'): one atomic per texel and chunk
//! instead of one per sprite and texel, the work spread by texels, and no work group longer than a chunk where
//! sprites pile up on a tile (a water surface seen at a grazing angle).
//! In: sprite records (noise_bin), tiles (counts, starts, first chunks), lists, the fluid depth. Out: the
//! accumulator atlas (r32ui); work[3] (texels evaluated), work[7] (the longest tile list).
#include "common.glsl"
#include "noise.glsl"
layout(local_size_x = NOISE_TILE, local_size_y = NOISE_TILE) in;
layout(std430, set = 0, binding = 1) readonly buffer Sprites { vec4 sprites[]; };
layout(std430, set = 0, binding = 2) readonly buffer Tiles { uint tiles[]; };
layout(std430, set = 0, binding = 3) readonly buffer Lists { uint lists[]; };
layout(set = 0, binding = 4, r32f) uniform readonly image2D depth;
// Holds the small sprites' terms (noise_bin): a tile's sum is added to them.
layout(set = 0, binding = 5, r32ui) uniform uimage2D accum;
layout(std430, set = 0, binding = 6) buffer Work { uint work[8]; };
#include "work_count.glsl"
#include "noise_push.glsl"
#define NOISE_TERM_ONLY
#include "noise_splat.glsl"

#define BATCH NOISE_CHUNK
shared vec4 s_a[BATCH];
shared vec4 s_b[BATCH];
shared float s_reach[BATCH];
shared uint s_evaluated;
shared uint s_tile;

void main() {
    uint li = gl_LocalInvocationIndex;
    // The chunk's tile: the last tile whose first chunk is at most this one (tiles with empty lists share
    // their first chunk with the next tile).
    uint chunk = gl_WorkGroupID.x;
    if (li == 0u) {
        uint lo = 0u, hi = pc.tiles - 1u;
        while (lo < hi) {
            uint mid = (lo + hi + 1u) >> 1;
            if (tiles[3u * pc.tiles + mid] <= chunk) lo = mid; else hi = mid - 1u;
        }
        s_tile = lo;
        s_evaluated = 0u;
    }
    barrier();
    uint tile = s_tile;
    ivec2 size = imageSize(depth);
    // The tile's level and place.
    int L = 0, base = 0;
    ivec2 nt = noise_tiles(size, 0);
    while (L < int(NOISE_LEVELS) && int(tile) >= base + nt.x * nt.y) {
        base += nt.x * nt.y;
        ++L;
        nt = noise_tiles(size, L);
    }
    int k = int(tile) - base;
    ivec2 q = ivec2(k % nt.x, k / nt.x) * int(NOISE_TILE) + ivec2(gl_LocalInvocationID.xy);
    bool inside = all(lessThan(q, noise_level_size(size, L)));
    float d = inside ? imageLoad(depth, noise_pick(q, L, size)).x : 1.0 / 0.0;
    bool fluid = inside && is_fluid(d);
    uint count = tiles[tile];
    uint first = (chunk - tiles[3u * pc.tiles + tile]) * BATCH;
    uint m = min(BATCH, count - min(first, count));
    if (li < m) {
        uint j = lists[tiles[pc.tiles + tile] + first + li];
        s_a[li] = sprites[2u * j];
        s_b[li] = sprites[2u * j + 1u];
        s_reach[li] = noise_reach(s_b[li].w);
    }
    barrier();
    int sum = 0;
    uint evaluated = 0u;
    if (fluid) {
        for (uint u = 0u; u < m; ++u) {
            vec4 a = s_a[u], b = s_b[u];
            int units;
            if (noise_term(q, L, a.xy, a.z, a.w, b.xyz, b.w, s_reach[u], d, units)) {
                ++evaluated;
                sum += units;
            }
        }
    }
    if (inside && sum != 0) imageAtomicAdd(accum, noise_level_base(size, L) + q, uint(sum));
    if (evaluated > 0u) atomicAdd(s_evaluated, evaluated);
    barrier();
    // Counted only in a frame that asks (work_count.glsl's WORK_COUNTING).
    if (li == 0u && WORK_COUNTING) {
        if (s_evaluated > 0u) atomicAdd(work[3], s_evaluated);
        if (first == 0u) atomicMax(work[7], count);
    }
}
