#version 460
//! noise_apply — the noise image's effect on the surface (NVIDIA patent US 8,947,430; method.md §8): the
//! accumulated noise N (radii of height) becomes a height field on the fluid, and its screen-space partial
//! derivatives, turned into slopes per world unit at the pixel's depth (× r · F / d), are added to the normal
//! (small waves): n' = normalize(n − k (∂h/∂X, ∂h/∂Y, 0)), view space. Along each axis the derivative is the
//! central difference where both neighbours are on the same surface (depth jump under `edge`), else one-sided,
//! else 0, as in `normals`.
//! N is level 0 of the accumulator atlas: the splat's fixed-point sums, or where the splat wrote coarser levels,
//! what noise_resolve wrote back over them (same fixed point); this pass also writes N as the composite's layer.
//! One image and one load per neighbour whatever the levels (a choice between two images per load cost lavapipe
//! both loads: its SIMD lanes run every branch). Tried and not kept: resolving the coarse levels here as well —
//! each neighbour again (the worst case's `noise` 0.365 against 0.251 ms on the H100) or once per work group and
//! border into shared memory (its `noise/apply` 0.088 against 0.068 for the two dispatches); on lavapipe the
//! first cost twice the two dispatches (3.2 → 6.3 ms, the wave at 480×270).
//! In: the accumulator atlas (r32ui; level 0 read), fluid depth (full resolution). Out: noise (r32ui holding f32
//! bits, N in radii, 0 off the fluid: a composite layer), normals (r32ui octahedral, perturbed in place).
#include "common.glsl"
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
layout(set = 0, binding = 1, r32ui) uniform readonly uimage2D accum;
layout(set = 0, binding = 2, r32f) uniform readonly image2D depth;
layout(set = 0, binding = 3, r32ui) uniform writeonly uimage2D noise; // f32 bits: a composite layer
layout(set = 0, binding = 4, r32ui) uniform uimage2D normals;
layout(push_constant) uniform Push {
    float strength; // scale of the slopes added to the normal
    float edge;     // depth jump (world units) that separates two surfaces
} pc;

ivec2 g_size;

/// N at pixel q (radii): level 0's fixed-point value.
float height(ivec2 q) { return float(int(imageLoad(accum, q).x)) * (1.0 / 65536.0); }

bool same(ivec2 q, float d) {
    if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, g_size))) return false;
    float dq = imageLoad(depth, q).x;
    return is_fluid(dq) && abs(dq - d) < pc.edge;
}

/// dN per pixel along `step`.
float slope(ivec2 p, float d, float n0, ivec2 step) {
    bool f = same(p + step, d), b = same(p - step, d);
    if (f && b) return 0.5 * (height(p + step) - height(p - step));
    if (f) return height(p + step) - n0;
    if (b) return n0 - height(p - step);
    return 0.0;
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    g_size = imageSize(depth);
    if (any(greaterThanEqual(p, g_size))) return;
    float d = imageLoad(depth, p).x;
    float n0 = is_fluid(d) ? height(p) : 0.0;
    imageStore(noise, p, uvec4(floatBitsToUint(n0)));
    if (!is_fluid(d)) return;
    // World units of height per pixel step, per world unit across: r · F / d.
    float k = pc.strength * frame.fluid.x * focal_for(float(g_size.y)) / d;
    float gx = slope(p, d, n0, ivec2(1, 0)) * k;
    float gy = -slope(p, d, n0, ivec2(0, 1)) * k; // image y grows downwards, view Y upwards
    vec3 n = unpack_normal(imageLoad(normals, p).x);
    imageStore(normals, p, uvec4(pack_normal(normalize(n - vec3(gx, gy, 0.0)))));
}
