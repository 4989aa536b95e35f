#version 460
//! thickness_blur — the second dispatch of the `thickness` pass: a 2D Gaussian over the fixed-point
//! accumulator, converted to world units (Moritz §3.2.2: thickness is blurred, its detail does not matter).
//! In: accumulator (r32ui). Out: thickness (r32f, world units). radius 0 = plain conversion.
#include "common.glsl"
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
layout(set = 0, binding = 1, r32ui) uniform readonly uimage2D accum;
layout(set = 0, binding = 2, r32f) uniform writeonly image2D thickness;
layout(push_constant) uniform Push { int radius; float sigma; } pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(accum);
    if (any(greaterThanEqual(p, size))) return;
    float sum = 0.0, wsum = 0.0;
    float k = 1.0 / (2.0 * pc.sigma * pc.sigma);
    for (int dy = -pc.radius; dy <= pc.radius; ++dy) {
        for (int dx = -pc.radius; dx <= pc.radius; ++dx) {
            ivec2 q = clamp(p + ivec2(dx, dy), ivec2(0), size - 1);
            float w = exp(-float(dx * dx + dy * dy) * k);
            sum += w * float(imageLoad(accum, q).x);
            wsum += w;
        }
    }
    imageStore(thickness, p, vec4(sum / wsum / frame.fluid.z));
}
