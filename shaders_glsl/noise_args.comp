#version 460
//! noise_args — the per-sprite splat's (CPU drivers) indirect dispatches, by one invocation after noise_cull:
//! noise.comp's work groups over the listed sprites (work[6]; none when nothing draws), and noise_resolve's: its
//! work groups when a sprite is evaluated on a level coarser than 0 (work[0], the coarsest level, is final
//! after the cull), none at level 0 alone — the normals and the composite then read level 0's sums as they are.
//! (The tiled splat's noise_scan writes the same.) Written here rather than by the cull's own invocations: on
//! lavapipe their atomics on the dispatch's words from both cores cost the worst case 15 ms at 480×270.
//! In: work[0], work[6]. Out: args (noise_resolve's 3 u32 at 0, noise.comp's at 4). NVIDIA patent US 8,947,430;
//! the levels are noise.comp's.
layout(local_size_x = 1) in;
layout(std430, set = 0, binding = 0) readonly buffer Work { uint work[8]; };
layout(std430, set = 0, binding = 1) writeonly buffer Args { uint args[8]; };
#include "noise_push.glsl"

void main() {
    bool coarse = work[0] > 0u;
    args[0] = coarse ? pc.resolve.x : 0u;
    args[1] = coarse ? pc.resolve.y : 0u;
    args[2] = coarse ? 1u : 0u;
    args[4] = (work[6] + LOCAL_1D - 1u) / LOCAL_1D;
    args[5] = 1u;
    args[6] = 1u;
}
