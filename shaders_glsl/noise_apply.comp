#version 460
//! noise_apply — the noise image's effect on the surface (NVIDIA patent US 8,947,430; method.md §8): the
//! accumulated noise N (radii of height) becomes a height field on the fluid, and its screen-space partial
//! derivatives, turned into slopes per world unit at the pixel's depth (× r · F / d), are added to the normal
//! (small waves): n' = normalize(n − k (∂h/∂X, ∂h/∂Y, 0)), view space. Along each axis the derivative is the
//! central difference where both neighbours are on the same surface (depth jump under `edge`), else one-sided,
//! else 0, as in `normals`.
//! In: noise (r32ui holding f32 bits, N in radii: noise_resolve.comp), fluid depth (full resolution), normals (r32ui octahedral).
//! Out: normals (perturbed in place).
//! NOISE_APPLY_RESOLVE (GPUs): no noise_resolve dispatch before it — each work group resolves N from the
//! accumulator atlas (noise_resolve.glsl) over its pixels and a one-pixel border into shared memory, writes
//! its pixels' N to the noise image and takes the derivatives from there. In: the atlas, depth, the splat's
//! work counts; out: noise, normals. On lavapipe a variant resolving each neighbour again cost twice the two
//! dispatches it replaces (3.2 → 6.3 ms, the wave at 480×270), and llvmpipe's barriers are slow: the CPU
//! driver keeps noise_resolve.comp.
#include "common.glsl"
#ifdef NOISE_APPLY_RESOLVE
#include "noise.glsl"
#endif
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
#ifdef NOISE_APPLY_RESOLVE
layout(set = 0, binding = 1, r32ui) uniform readonly uimage2D accum;
layout(set = 0, binding = 2, r32f) uniform readonly image2D depth;
layout(set = 0, binding = 3, r32ui) uniform writeonly uimage2D noise; // f32 bits: a composite layer
layout(set = 0, binding = 4, r32ui) uniform uimage2D normals;
// The splat's work counts: [0] the coarsest level it wrote.
layout(std430, set = 0, binding = 5) readonly buffer Work { uint work[4]; };
#include "noise_resolve.glsl"
#else
layout(set = 0, binding = 1, r32ui) uniform readonly uimage2D noise; // f32 bits
layout(set = 0, binding = 2, r32f) uniform readonly image2D depth;
layout(set = 0, binding = 3, r32ui) uniform uimage2D normals;
#endif
layout(push_constant) uniform Push {
    float strength; // scale of the slopes added to the normal
    float edge;     // depth jump (world units) that separates two surfaces
} pc;

ivec2 g_size;

#ifdef NOISE_APPLY_RESOLVE
// N over the work group's pixels and a one-pixel border (0 off the image and where there is no fluid), each
// resolved once: the derivatives read the neighbours' from here (resolving them again cost the worst case,
// whose coarse levels each take four taps, 0.365 against 0.251 ms for the two dispatches on the H100).
const int TILE = int(LOCAL_2D) + 2;
shared float s_n[TILE * TILE];
ivec2 g_origin;
float height(ivec2 q) {
    ivec2 t = q - g_origin;
    return s_n[t.x + TILE * t.y];
}
#else
float height(ivec2 q) { return uintBitsToFloat(imageLoad(noise, q).x); }
#endif

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
    g_size = imageSize(noise);
#ifdef NOISE_APPLY_RESOLVE
    g_origin = ivec2(gl_WorkGroupID.xy) * int(LOCAL_2D) - 1;
    int levels = int(min(work[0], uint(NOISE_LEVELS)));
    for (uint k = gl_LocalInvocationIndex; k < uint(TILE * TILE); k += LOCAL_2D * LOCAL_2D) {
        ivec2 q = g_origin + ivec2(int(k) % TILE, int(k) / TILE);
        bool inside = all(greaterThanEqual(q, ivec2(0))) && all(lessThan(q, g_size));
        s_n[k] = inside && is_fluid(imageLoad(depth, q).x) ? noise_resolve(q, g_size, levels) : 0.0;
    }
    barrier();
    if (any(greaterThanEqual(p, g_size))) return;
    float d = imageLoad(depth, p).x;
    float n0 = height(p);
    imageStore(noise, p, uvec4(floatBitsToUint(n0)));
    if (!is_fluid(d)) return;
#else
    if (any(greaterThanEqual(p, g_size))) return;
    float d = imageLoad(depth, p).x;
    if (!is_fluid(d)) return;
    float n0 = height(p);
#endif
    // World units of height per pixel step, per world unit across: r · F / d.
    float k = pc.strength * frame.fluid.x * focal_for(float(g_size.y)) / d;
    float gx = slope(p, d, n0, ivec2(1, 0)) * k;
    float gy = -slope(p, d, n0, ivec2(0, 1)) * k; // image y grows downwards, view Y upwards
    vec3 n = unpack_normal(imageLoad(normals, p).x);
    imageStore(normals, p, uvec4(pack_normal(normalize(n - vec3(gx, gy, 0.0)))));
}
