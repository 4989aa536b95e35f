#version 460
//! noise — the patent's noise image (NVIDIA patent US 8,947,430, eq. 15–17), every sprite by its
//! own thread: each particle that draws (noise_cull.comp listed it) splats its Gaussian sprite of per-particle 3D
//! noise (noise.glsl), weighted by how deep the particle lies below the fluid surface at each texel and scaled by
//! its amplitude (calm, or raised while its velocity changes fast), into a fixed-point accumulator atlas (2^16
//! units per particle radius of height; signed values added as two's-complement uints, so the sum is exact and
//! independent of the order of the atomics). The splat for CPU drivers (lavapipe), where a work group's lanes are
//! SIMD lanes of one core and one thread per sprite with atomics is the cheapest; GPUs bin the sprites to tiles
//! instead (noise_bin.comp, noise_gather.comp: the same sums, no atomics). Dispatched indirectly over the listed
//! sprites (noise_args.comp writes the work groups), so the texel loop's lanes are sprites that draw.
//! Work follows the visible surface (noise_splat.glsl, noise.glsl): a sprite is evaluated on the coarsest
//! accumulator level that still samples its finer octave `[noise] lod_samples` (pc.lod) times per cycle, so a close-up sprite
//! hundreds of pixels across costs as many texels as one 40 pixels across; a texel where the particle lies
//! deeper than its term can reach is skipped before the noise is evaluated (exact: the term rounds to 0 there).
//! Level 0 is evaluated exactly as the CPU reference (`passes::noise::reference`) does.
//! In: particles (vec4 xyz + w, then one motion vec4 per particle after the `count` positions: x = id bits,
//! y = |Δv|/Δt), the fluid depth (full resolution), the listed particle indices and work[6], their count. Out: the
//! accumulator atlas (r32ui, cleared to 0); the work counts.
// The work counters' subgroup sums (work_count.glsl).
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "common.glsl"
#include "sphere.glsl"
#include "noise.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, set = 0, binding = 1) readonly buffer Particles { vec4 particles[]; };
layout(set = 0, binding = 2, r32f) uniform readonly image2D depth;
layout(set = 0, binding = 3, r32ui) uniform uimage2D accum;
// The pass's work (cleared to 0 before it): [0] the coarsest level written, [1] texels visited (each sprite's
// rectangle at its level), [2] sprites drawn, [3] texels whose noise was evaluated, [4] sprites left out (more
// than NOISE_MAX_TILES tiles: the tiled splat), [5] tile-list entries (the tiled splat), [6] sprites listed
// (noise_cull) or binned (noise_bin), [7] the longest tile list (the tiled splat).
layout(std430, set = 0, binding = 4) buffer Work { uint work[8]; };
layout(std430, set = 0, binding = 5) readonly buffer Listed { uint listed[]; };
#include "noise_push.glsl"
#include "noise_splat.glsl"

#include "work_count.glsl"

void main() {
    uint k = gl_GlobalInvocationID.x;
    if (k >= work[6]) return;
    ivec2 size = imageSize(depth);
    Sprite s;
    uint texels = 0u, evaluated = 0u;
    // Listed: it draws (the same cull, the same result).
    if (noise_sprite_of(listed[k], size, s)) {
        evaluated = noise_splat_alone(s, size);
        texels = uint(s.hi.x - s.lo.x + 1) * uint(s.hi.y - s.lo.y + 1);
    }
    WORK_ADD(work[1], texels);
    WORK_ADD(work[3], evaluated);
}
