#version 460
//! noise_fill — the tiled noise splat's lists (GPUs; NVIDIA patent US 8,947,430): after noise_scan
//! gave each tile its list's start, each binned sprite (noise_bin appended their indices; this pass is dispatched
//! indirectly, one thread per binned sprite) writes its particle index into the list of every tile its
//! rectangle touches, its level and rectangle recomputed from its record as noise_bin computed them.
//! In: sprite records, the binned sprites' indices, work[6] (how many), the fluid depth (its size). Out: the
//! tile lists (tiles[2n + t] is tile t's cursor).
#include "noise.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, set = 0, binding = 0) readonly buffer Sprites { vec4 sprites[]; };
layout(std430, set = 0, binding = 1) readonly buffer Binned { uint binned[]; };
layout(std430, set = 0, binding = 2) readonly buffer Work { uint work[8]; };
layout(set = 0, binding = 3, r32f) uniform readonly image2D depth;
layout(std430, set = 0, binding = 4) buffer Tiles { uint tiles[]; };
layout(std430, set = 0, binding = 5) writeonly buffer Lists { uint lists[]; };
#include "noise_push.glsl"

void main() {
    uint k = gl_GlobalInvocationID.x;
    if (k >= work[6]) return;
    uint i = binned[k];
    ivec2 size = imageSize(depth);
    vec4 a = sprites[2u * i];
    // The sprite's level and rectangle, from its record (centre a.xy, radius a.z), as noise_bin found them.
    int L = noise_level(a.z, pc.freq, pc.lod);
    ivec2 lo, hi;
    noise_rect(a.xy, a.z, L, size, lo, hi);
    ivec2 t0 = lo / int(NOISE_TILE), t1 = hi / int(NOISE_TILE);
    int base = noise_tile_base(size, L);
    int row = noise_tiles(size, L).x;
    for (int ty = t0.y; ty <= t1.y; ++ty) {
        for (int tx = t0.x; tx <= t1.x; ++tx) {
            uint t = uint(base + ty * row + tx);
            lists[atomicAdd(tiles[2u * pc.tiles + t], 1u)] = i;
        }
    }
}
