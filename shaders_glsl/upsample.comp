#version 460
//! upsample — silhouette-aware upsampling of the reduced-resolution fluid depth to full resolution (NVIDIA
//! patent US 8,947,430: low-resolution passes with silhouette-aware upscaling; Moritz §5 renders the fluid at half
//! resolution). Inside the fluid, where all four bilinear neighbours are fluid and lie within `edge` of each
//! other, the depth is interpolated bilinearly; anywhere else (silhouettes, one surface in front of another) the
//! nearest low-resolution sample is taken, so no output depth ever lies between two separated surfaces.
//! In: low-resolution depth (r32f). Out: full-resolution depth (r32f, +inf = no fluid).
#include "common.glsl"
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
layout(set = 0, binding = 1, r32f) uniform readonly image2D low;
layout(set = 0, binding = 2, r32f) uniform writeonly image2D full;
layout(push_constant) uniform Push { float edge; } pc; // world depth jump that separates surfaces

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(full);
    if (any(greaterThanEqual(p, size))) return;
    ivec2 lsize = imageSize(low);
    vec2 c = (vec2(p) + 0.5) * vec2(lsize) / vec2(size) - 0.5;
    ivec2 i0 = ivec2(floor(c));
    vec2 f = c - vec2(i0);
    ivec2 lo = ivec2(0), hi = lsize - 1;
    float d00 = imageLoad(low, clamp(i0, lo, hi)).x;
    float d10 = imageLoad(low, clamp(i0 + ivec2(1, 0), lo, hi)).x;
    float d01 = imageLoad(low, clamp(i0 + ivec2(0, 1), lo, hi)).x;
    float d11 = imageLoad(low, clamp(i0 + ivec2(1, 1), lo, hi)).x;
    float dmin = min(min(d00, d10), min(d01, d11));
    float dmax = max(max(d00, d10), max(d01, d11));
    float d;
    if (is_fluid(dmax) && dmax - dmin < pc.edge) {
        d = mix(mix(d00, d10, f.x), mix(d01, d11, f.x), f.y);
    } else {
        d = imageLoad(low, clamp(ivec2(round(c)), lo, hi)).x;
    }
    imageStore(full, p, vec4(d));
}
