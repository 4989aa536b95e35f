#version 460
//! noise_bin — the tiled noise splat's binning (GPUs; NVIDIA patent US 8,947,430, eq. 15–17): each
//! particle's sprite (noise_splat.glsl: its level of detail, rectangle and culling, as noise.comp) of more than
//! `small` texels (a push constant, 64 by default) is counted into every tile (NOISE_TILE² texels of its level)
//! its rectangle touches, its record (centre, R, z; offset, amplitude) written for noise_fill and noise_gather,
//! and its index appended to the binned sprites (work[6] counts them). A sprite of at most `small` texels is
//! splatted here, with atomics, as noise.comp does: a tile's work group tests each of its sprites at all its
//! texels, which pays for a sprite hundreds of texels across and not for one a few texels across (the 814k
//! waterfall at 960×540: 4.6 ms all tiled, 0.23 ms with atomics, on an H100).
//! In: particles (positions, then motions), the fluid depth. Out: tile counts, sprite records (2 vec4 per
//! particle), the binned sprites' indices, work counts, the small sprites' terms in the accumulator atlas.
// The work counters' subgroup sums (work_count.glsl).
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "common.glsl"
#include "sphere.glsl"
#include "noise.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, set = 0, binding = 1) readonly buffer Particles { vec4 particles[]; };
layout(set = 0, binding = 2, r32f) uniform readonly image2D depth;
// [0, n): each tile's sprite count; [n, 2n): its list's start (noise_scan); [2n, 3n): its fill cursor.
layout(std430, set = 0, binding = 3) buffer Tiles { uint tiles[]; };
layout(std430, set = 0, binding = 4) writeonly buffer Sprites { vec4 sprites[]; };
// The work counts (noise.comp's layout; [6]: sprites binned).
layout(std430, set = 0, binding = 5) buffer Work { uint work[8]; };
// The accumulator atlas (cleared to 0 before): the small sprites' terms.
layout(set = 0, binding = 6, r32ui) uniform uimage2D accum;
layout(std430, set = 0, binding = 7) writeonly buffer Binned { uint binned[]; };
#include "noise_push.glsl"
#include "noise_splat.glsl"

#include "work_count.glsl"

/// Particle i's sprite: splatted here with atomics when it is small, else binned to the tiles it covers. Its
/// work counts: w = (level, texels, drawn, evaluated), v = (left out, tile-list entries).
void bin_sprite(uint i, inout uvec4 w, inout uvec2 v) {
    ivec2 size = imageSize(depth);
    Sprite s;
    if (!noise_sprite_of(i, size, s)) return;
    uint texels = uint(s.hi.x - s.lo.x + 1) * uint(s.hi.y - s.lo.y + 1);
    w.xyz = uvec3(uint(s.L), texels, 1u);
    if (texels <= pc.small) {
        w.w = noise_splat_alone(s, size);
        return;
    }
    ivec2 t0 = s.lo / int(NOISE_TILE), t1 = s.hi / int(NOISE_TILE);
    uint n = uint(t1.x - t0.x + 1) * uint(t1.y - t0.y + 1);
    // Only a sprite larger than the screen at the coarsest level (the camera inside the water) spans more.
    if (n > NOISE_MAX_TILES) {
        v.x = 1u;
        return;
    }
    int base = noise_tile_base(size, s.L);
    int row = noise_tiles(size, s.L).x;
    for (int ty = t0.y; ty <= t1.y; ++ty) {
        for (int tx = t0.x; tx <= t1.x; ++tx) atomicAdd(tiles[uint(base + ty * row + tx)], 1u);
    }
    sprites[2u * i] = vec4(s.centre, s.R, s.z);
    sprites[2u * i + 1u] = vec4(s.o, s.amp);
    binned[atomicAdd(work[6], 1u)] = i;
    v.y = n;
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    uvec4 w = uvec4(0u);
    uvec2 v = uvec2(0u);
    bin_sprite(i, w, v);
    WORK_MAX(work[0], w.x);
    WORK_ADD(work[1], w.y);
    WORK_ADD(work[2], w.z);
    WORK_ADD(work[3], w.w);
    WORK_ADD(work[4], v.x);
    WORK_ADD(work[5], v.y);
}
