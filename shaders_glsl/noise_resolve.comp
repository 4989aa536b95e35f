#version 460
//! noise_resolve — the noise N (radii of height) where the `noise` pass's splat wrote coarser levels than 0:
//! level 0's fixed-point sum at the pixel plus every coarser level's sum interpolated bilinearly at the pixel
//! (texel i of level L sits at full-resolution position (i + ½)·2^L − ½), written back over level 0's sum in the
//! same fixed point (rounded to 2^-16 radii), so that the normals (their detail) and the composite (its
//! whitecaps layer) read one image whether or not this ran. A coarse texel whose depth pixel showed no fluid was
//! never written: it is left out of the interpolation and the weights of the others renormalised, so a close-up
//! sprite's noise reaches the silhouette instead of fading towards it. Dispatched indirectly, with no work groups when the splat wrote level 0 alone (noise_scan or
//! noise_args writes the count). NVIDIA patent US 8,947,430 (eq. 15–17); the level of detail is
//! noise.comp's.
//! In: the accumulator atlas (r32ui), fluid depth (full resolution), the splat's work counts (its coarsest
//! level). Out: the atlas's level 0 (N, fixed point; each invocation writes its own pixel's texel, which no
//! other reads).
#include "common.glsl"
#include "noise.glsl"
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
layout(set = 0, binding = 1, r32ui) uniform uimage2D accum;
layout(set = 0, binding = 2, r32f) uniform readonly image2D depth;
// noise.comp's work counts: [0] the coarsest level it wrote.
layout(std430, set = 0, binding = 3) readonly buffer Work { uint work[4]; };

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(depth);
    if (any(greaterThanEqual(p, size)) || !is_fluid(imageLoad(depth, p).x)) return;
    float n = float(int(imageLoad(accum, p).x));
    int levels = int(min(work[0], uint(NOISE_LEVELS)));
    for (int L = 1; L <= levels; ++L) {
        ivec2 lsize = noise_level_size(size, L);
        ivec2 base = noise_level_base(size, L);
        vec2 t = (vec2(p) + 0.5) / float(1 << L) - 0.5;
        ivec2 i0 = ivec2(floor(t));
        vec2 f = t - vec2(i0);
        float sum = 0.0, wsum = 0.0;
        for (int k = 0; k < 4; ++k) {
            ivec2 o = ivec2(k & 1, k >> 1);
            ivec2 q = clamp(i0 + o, ivec2(0), lsize - 1);
            float w = (o.x == 1 ? f.x : 1.0 - f.x) * (o.y == 1 ? f.y : 1.0 - f.y);
            ivec2 pick = min(q * (1 << L) + (1 << (L - 1)), size - 1);
            if (w > 0.0 && is_fluid(imageLoad(depth, pick).x)) {
                sum += w * float(int(imageLoad(accum, base + q).x));
                wsum += w;
            }
        }
        if (wsum > 0.0) n += sum / wsum;
    }
    imageStore(accum, p, uvec4(uint(int(round(n)))));
}
