#version 460
//! noise_cull — the per-sprite noise splat's first half (CPU drivers; NVIDIA patent US 8,947,430, eq. 15–17): every particle's sprite is culled as noise_splat.glsl's `noise_sprite_at` does (isolated,
//! behind the camera, off screen, over budget, or deeper below the surface at its centre than its term can reach)
//! and the index of each one that draws is appended to the list noise.comp walks (one atomic per subgroup).
//! Why apart from the texels: lavapipe runs a work group's invocations as SIMD lanes and a branch as masked
//! lanes, so a sprite loop in the same invocation as the cull is run, masked, by every vector of culled particles
//! too — on the waterfall 151k of 814k particles draw and the fused splat cost 32–34 ms, the cull alone 10–16
//! (docs/gpu-frame.md). The coarsest level written is kept here too (noise_args: noise_resolve's dispatch).
//! In: particles (positions, then motions), the fluid depth. Out: the listed particle indices, work[6] (how many),
//! work[0] (the coarsest level), work[2] (sprites drawn, counted frames only).
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_ballot : require
#include "common.glsl"
#include "sphere.glsl"
#include "noise.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, set = 0, binding = 1) readonly buffer Particles { vec4 particles[]; };
layout(set = 0, binding = 2, r32f) uniform readonly image2D depth;
// The work counts (noise.comp's layout; [6]: sprites listed).
layout(std430, set = 0, binding = 3) buffer Work { uint work[8]; };
layout(std430, set = 0, binding = 4) writeonly buffer Listed { uint listed[]; };
#include "noise_push.glsl"
#define NOISE_CULL_ONLY
#include "noise_splat.glsl"

#include "work_count.glsl"

void main() {
    uint i = gl_GlobalInvocationID.x;
    Sprite s;
    bool draws = i < pc.count && noise_sprite_at(i, imageSize(depth), s);
    uvec4 ballot = subgroupBallot(draws);
    uint n = subgroupBallotBitCount(ballot);
    uint first = 0u;
    if (subgroupElect() && n > 0u) first = atomicAdd(work[6], n);
    first = subgroupBroadcastFirst(first);
    if (draws) listed[first + subgroupBallotExclusiveBitCount(ballot)] = i;
    WORK_MAX(work[0], draws ? uint(s.L) : 0u);
    WORK_ADD(work[2], draws ? 1u : 0u);
}
