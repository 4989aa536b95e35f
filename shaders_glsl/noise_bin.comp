#version 460
//! noise_bin — the tiled noise splat's binning (GPUs; NVIDIA patent US 8,947,430, eq. 15–17; method.md §8): each
//! particle's sprite (noise_splat.glsl: its level of detail, rectangle and culling, as noise.comp) of more than
//! `small` texels (a push constant, 64 by default) is counted into every tile (NOISE_TILE² texels of its level) its rectangle touches; with
//! NOISE_FILL, after noise_scan gave each tile its start, the particle's index is written into those tiles'
//! lists instead. The count pass also writes the sprite's record (centre, R, z; offset, amplitude) for
//! noise_gather and the work counts, and splats a sprite of at most `small` texels itself, with atomics, as
//! noise.comp does: a tile's work group tests each of its sprites at all its texels, which pays for a sprite
//! hundreds of texels across and not for one a few texels across (the 814k waterfall at 960×540: 4.6 ms tiled,
//! 0.23 ms with atomics, on an H100).
//! In: particles (positions, then motions), the fluid depth. Out: tile counts, sprite records (2 vec4 per
//! particle), work counts and the small sprites' terms in the accumulator atlas (count pass); or the tile lists
//! (fill pass: tiles[2n + t] is tile t's cursor).
#include "common.glsl"
#include "sphere.glsl"
#include "noise.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, set = 0, binding = 1) readonly buffer Particles { vec4 particles[]; };
layout(set = 0, binding = 2, r32f) uniform readonly image2D depth;
// [0, n): each tile's sprite count; [n, 2n): its list's start (noise_scan); [2n, 3n): its fill cursor.
layout(std430, set = 0, binding = 3) buffer Tiles { uint tiles[]; };
#ifdef NOISE_FILL
layout(std430, set = 0, binding = 4) writeonly buffer Lists { uint lists[]; };
#else
layout(std430, set = 0, binding = 4) writeonly buffer Sprites { vec4 sprites[]; };
// The work counts (noise.comp's layout).
layout(std430, set = 0, binding = 5) buffer Work { uint work[8]; };
// The accumulator atlas (cleared to 0 before): the small sprites' terms.
layout(set = 0, binding = 6, r32ui) uniform uimage2D accum;
#endif

layout(push_constant) uniform Push {
    uint count;
    float size;
    float freq;
    float falloff;
    float calm;
    float turbulent;
    float threshold;
    uint tiles;      // n: tiles of every level
    uint small;      // sprites of at most this many texels are not binned (noise_bin)
} pc;
#include "noise_splat.glsl"

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    ivec2 size = imageSize(depth);
    Sprite s;
    if (!noise_sprite_of(i, size, s)) return;
    uint texels = uint(s.hi.x - s.lo.x + 1) * uint(s.hi.y - s.lo.y + 1);
    if (texels <= pc.small) {
#ifndef NOISE_FILL
        ivec2 base = noise_level_base(size, s.L);
        uint evaluated = 0u;
        for (int y = s.lo.y; y <= s.hi.y; ++y) {
            for (int x = s.lo.x; x <= s.hi.x; ++x) {
                ivec2 q = ivec2(x, y);
                float d = imageLoad(depth, noise_pick(q, s.L, size)).x;
                if (!is_fluid(d)) continue;
                int units;
                if (noise_term(q, s.L, s.centre, s.R, s.z, s.o, s.amp, s.reach, d, units)) {
                    ++evaluated;
                    if (units != 0) imageAtomicAdd(accum, base + q, uint(units));
                }
            }
        }
        atomicMax(work[0], uint(s.L));
        atomicAdd(work[1], texels);
        atomicAdd(work[2], 1u);
        atomicAdd(work[3], evaluated);
#endif
        return;
    }
    ivec2 t0 = s.lo / int(NOISE_TILE), t1 = s.hi / int(NOISE_TILE);
    uint n = uint(t1.x - t0.x + 1) * uint(t1.y - t0.y + 1);
    // Only a sprite larger than the screen at the coarsest level (the camera inside the water) spans more.
    if (n > NOISE_MAX_TILES) {
#ifndef NOISE_FILL
        atomicAdd(work[4], 1u);
#endif
        return;
    }
    int base = noise_tile_base(size, s.L);
    int row = noise_tiles(size, s.L).x;
    for (int ty = t0.y; ty <= t1.y; ++ty) {
        for (int tx = t0.x; tx <= t1.x; ++tx) {
            uint t = uint(base + ty * row + tx);
#ifdef NOISE_FILL
            lists[atomicAdd(tiles[2u * pc.tiles + t], 1u)] = i;
#else
            atomicAdd(tiles[t], 1u);
#endif
        }
    }
#ifndef NOISE_FILL
    sprites[2u * i] = vec4(s.centre, s.R, s.z);
    sprites[2u * i + 1u] = vec4(s.o, s.amp);
    atomicMax(work[0], uint(s.L));
    atomicAdd(work[1], texels);
    atomicAdd(work[2], 1u);
    atomicAdd(work[5], n);
#endif
}
