#version 460
//! noise_resolve — the noise image N (radii of height) from the `noise` pass's accumulator atlas
//! (noise_resolve.glsl: level 0's sum plus the coarser levels' interpolated), 0 where there is no fluid.
//! With the tiled splat (GPUs) it is dispatched indirectly, with no work groups when the splat wrote level 0
//! alone (noise_scan writes the count): noise_apply (NOISE_APPLY_RESOLVE) then writes N from the sums itself.
//! NVIDIA patent US 8,947,430 (eq. 15–17; method.md §8); the level of detail is noise.comp's.
//! In: accumulator atlas (r32ui), fluid depth (full resolution), the splat's work counts (its coarsest level).
//! Out: noise (r32ui holding f32 bits: the composite reads it as a layer, `crate::effect::Blend::Tint`).
#include "common.glsl"
#include "noise.glsl"
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
layout(set = 0, binding = 1, r32ui) uniform readonly uimage2D accum;
layout(set = 0, binding = 2, r32f) uniform readonly image2D depth;
layout(set = 0, binding = 3, r32ui) uniform writeonly uimage2D noise; // f32 bits: a composite layer
// noise.comp's work counts: [0] the coarsest level it wrote.
layout(std430, set = 0, binding = 4) readonly buffer Work { uint work[4]; };

#include "noise_resolve.glsl"

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(noise);
    int levels = int(min(work[0], uint(NOISE_LEVELS)));
    if (any(greaterThanEqual(p, size))) return;
    float n = is_fluid(imageLoad(depth, p).x) ? noise_resolve(p, size, levels) : 0.0;
    imageStore(noise, p, uvec4(floatBitsToUint(n)));
}
