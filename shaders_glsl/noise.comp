#version 460
//! noise — the patent's noise image (NVIDIA patent US 8,947,430, eq. 15–17; method.md §8): every particle splats
//! its Gaussian sprite of per-particle 3D noise (noise.glsl), weighted by how deep the particle lies below the
//! fluid surface at each pixel and scaled by its amplitude (calm, or raised while its velocity changes fast),
//! into a fixed-point accumulator (2^16 units per particle radius of height; signed values added as
//! two's-complement uints, so the sum is exact and independent of the order of the atomics).
//! Work follows the visible surface, not the particles:
//! - depth: a particle deeper below the surface at its sprite's centre than NOISE_DEEP falloffs plus the
//!   sprite's radius is culled; per texel, one deeper than its term can reach (`noise_reach`: where the term
//!   rounds to 0 fixed-point units, so the cut is exact) is skipped before the noise is evaluated;
//! - level of detail: a sprite is evaluated on the finest level L of the accumulator (texels of 2^L pixels)
//!   that still samples its finer octave NOISE_LOD_SAMPLES times per cycle — the noise has no finer detail —
//!   so a close-up sprite hundreds of pixels across costs as many samples as one a few dozen across;
//!   `noise_resolve` adds the coarse levels back, bilinearly. Sprites small enough for level 0 are evaluated
//!   exactly as the CPU reference (`passes::noise::reference`) does;
//! - balance: a sprite of at most NOISE_SMALL texels (32) is walked by its own thread; the larger ones of a work group
//!   lay their texels end to end (a prefix sum in shared memory) and the group's threads share them out, so one
//!   large sprite never leaves its warp idle.
//! The NOISE_ALONE variant (CPU drivers) walks every sprite by its own thread, with no shared memory.
//! Level L's texel (i, j) sits at full-resolution position (i + ½)·2^L − ½ and reads the depth of pixel
//! (i·2^L + 2^(L−1), j·2^L + 2^(L−1)). The accumulator is an atlas: level 0 at (0, 0), level L ≥ 1 at
//! (W, Σ_{1≤k<L} ⌈H/2^k⌉) (`noise_level_base`, noise.glsl).
//! In: particles (vec4 xyz + w, then one motion vec4 per particle after the `count` positions: x = id bits,
//! y = |Δv|/Δt), the fluid depth (full resolution). Out: accumulator atlas (r32ui), cleared to 0; the work
//! counts.
#include "common.glsl"
#include "sphere.glsl"
#include "noise.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, set = 0, binding = 1) readonly buffer Particles { vec4 particles[]; };
layout(set = 0, binding = 2, r32f) uniform readonly image2D depth;
layout(set = 0, binding = 3, r32ui) uniform uimage2D accum;
// The pass's work (cleared to 0 before it): [0] the coarsest level written, [1] texels visited (each sprite's
// rectangle at its level), [2] sprites drawn, [3] texels whose noise was evaluated.
layout(std430, set = 0, binding = 4) buffer Work { uint work[4]; };
layout(push_constant) uniform Push {
    uint count;
    float size;      // sprite radius in particle radii
    float freq;      // noise cycles across the sprite's radius
    float falloff;   // depth below the surface (radii) over which the weight falls by 1/e
    float calm;      // amplitude (radii of height) of a particle whose velocity changes slowly
    float turbulent; // … and of one whose velocity changes faster than the threshold
    float threshold; // velocity change (world units / s²)
} pc;

#ifdef NOISE_ALONE
// Every sprite by its own thread (CPU drivers: a work group's lanes are SIMD lanes of one core, where a scan
// and a search per texel in shared memory cost more than they save).
#define NOISE_SMALL 0xffffffffu
#else
// Sprites of at most this many texels are walked by their own thread (on a GPU a thread walking a large sprite
// holds its whole warp).
#define NOISE_SMALL 32u
#endif

#ifndef NOISE_ALONE
// The group's large sprites: centre (full-resolution pixels), radius R, eye depth z; offset, amplitude; the
// level's rectangle (lo, width) and the level, with the reach in falloffs; the end of each sprite's texels in
// the group's run (an inclusive scan).
shared vec4 s_shape[LOCAL_1D];
shared vec4 s_seed[LOCAL_1D];
shared ivec4 s_rect[LOCAL_1D];
shared float s_reach[LOCAL_1D];
shared uint s_end[LOCAL_1D];
shared uint s_level;
shared uint s_sprites;
shared uint s_evaluated;
shared uint s_large;
shared uint s_small_texels;
#endif

ivec2 g_size;
float g_inv_fall;

/// Add one texel q of level L of a sprite; true when its noise was evaluated.
bool splat(ivec2 q, int L, vec4 shape, vec4 seed, float reach) {
    vec2 pos = L == 0 ? vec2(q) : (vec2(q) + 0.5) * float(1 << L) - 0.5;
    vec2 uv = (pos - shape.xy) / shape.z;
    float qq = dot(uv, uv);
    if (qq > 1.0) return false;
    ivec2 pick = L == 0 ? q : min(q * (1 << L) + (1 << (L - 1)), g_size - 1);
    float d = imageLoad(depth, pick).x;
    if (!is_fluid(d)) return false;
    float below = (shape.w - d) * g_inv_fall;
    if (below > reach) return false;
    float v = seed.w * exp(-2.0 * qq) * noise_sprite(uv, pc.freq, seed.xyz) * exp(-below * below);
    int units = int(round(v * 65536.0));
    if (units != 0) imageAtomicAdd(accum, noise_level_base(g_size, L) + q, uint(units));
    return true;
}

void main() {
    uint t = gl_LocalInvocationID.x;
    uint i = gl_GlobalInvocationID.x;
    g_size = imageSize(depth);
    float r = frame.fluid.x;
    g_inv_fall = 1.0 / (pc.falloff * r);
#ifndef NOISE_ALONE
    if (t == 0u) {
        s_level = 0u;
        s_sprites = 0u;
        s_evaluated = 0u;
        s_large = 0u;
        s_small_texels = 0u;
    }
    barrier();
#endif
    uint texels = 0u, shared_texels = 0u, evaluated = 0u;
    vec4 shape, seed;
    ivec4 rect;
    float reach = 0.0;
    if (i < pc.count) {
        Particle pt = load_particle(particles[i], 1.0);
        vec4 motion = particles[pc.count + i];
        float z = -pt.c.z;
        // Spray is drawn apart from the surface: it adds no waves to it.
        if (!pt.spray && z > frame.proj.w) {
            float F = focal_for(float(g_size.y));
            // Sprite centre and radius in pixels (pixel_dir's convention: pixel p's centre is at p + 0.5).
            vec2 centre = vec2(0.5 * g_size.x + F * pt.c.x / z - 0.5, 0.5 * g_size.y - F * pt.c.y / z - 0.5);
            float R = F * pc.size * r / z;
            int L = noise_level(R, pc.freq);
            float cell = float(1 << L);
            // The texels whose positions lie within R of the centre (at level 0 the pixels, as the reference).
            vec2 lo_f = L == 0 ? ceil(centre - R) : ceil((centre - R + 0.5) / cell - 0.5);
            vec2 hi_f = L == 0 ? floor(centre + R) : floor((centre + R + 0.5) / cell - 0.5);
            ivec2 lo = max(ivec2(lo_f), ivec2(0));
            ivec2 hi = min(ivec2(hi_f), noise_level_size(g_size, L) - 1);
            float amp = noise_amplitude(motion.y, pc.calm, pc.turbulent, pc.threshold);
            reach = noise_reach(amp);
            // Deep in the water: a particle more than DEEP falloffs (plus its sprite's radius, for a sloped
            // surface) below the surface at its centre is taken to add nothing anywhere (the reference's rule).
            ivec2 mid = clamp(ivec2(round(centre)), ivec2(0), g_size - 1);
            float dc = imageLoad(depth, mid).x;
            bool deep = is_fluid(dc) && z - dc > (NOISE_DEEP * pc.falloff + pc.size) * r;
            if (!deep && all(lessThanEqual(lo, hi)) && !over_budget(lo, hi)) {
                texels = uint(hi.x - lo.x + 1) * uint(hi.y - lo.y + 1);
                shape = vec4(centre, R, z);
                seed = vec4(noise_offset(floatBitsToUint(motion.x)), amp);
                rect = ivec4(lo, hi.x - lo.x + 1, L);
#ifndef NOISE_ALONE
                atomicMax(s_level, uint(L));
                atomicAdd(s_sprites, 1u);
                if (texels > NOISE_SMALL) {
                    atomicAdd(s_large, 1u);
                    shared_texels = texels;
                    s_shape[t] = shape;
                    s_seed[t] = seed;
                    s_rect[t] = rect;
                    s_reach[t] = reach;
                }
#endif
            }
        }
    }
    // A small sprite: its own thread walks it.
    if (texels > 0u && texels <= NOISE_SMALL) {
        for (int y = 0; y < int(texels) / rect.z; ++y) {
            for (int x = 0; x < rect.z; ++x) {
                if (splat(rect.xy + ivec2(x, y), rect.w, shape, seed, reach)) ++evaluated;
            }
        }
    }
#ifdef NOISE_ALONE
    if (texels > 0u) {
        atomicMax(work[0], uint(rect.w));
        atomicAdd(work[1], texels);
        atomicAdd(work[2], 1u);
        atomicAdd(work[3], evaluated);
    }
#else
    // The large ones: end to end, shared out over the group (Hillis–Steele inclusive scan of their sizes); a
    // group without any skips the scan (s_large is the same for every thread: uniform control flow).
    s_end[t] = shared_texels;
    barrier();
    uint total = 0u;
    if (s_large > 0u) {
        for (uint off = 1u; off < LOCAL_1D; off <<= 1) {
            uint add = t >= off ? s_end[t - off] : 0u;
            barrier();
            s_end[t] += add;
            barrier();
        }
        total = s_end[LOCAL_1D - 1u];
        for (uint k = t; k < total; k += LOCAL_1D) {
            // The sprite whose run holds texel k: the first with s_end > k.
            uint a = 0u, b = LOCAL_1D - 1u;
            while (a < b) {
                uint m = (a + b) >> 1;
                if (s_end[m] > k) b = m; else a = m + 1u;
            }
            uint local = k - (a > 0u ? s_end[a - 1u] : 0u);
            ivec4 rc = s_rect[a];
            ivec2 q = rc.xy + ivec2(int(local % uint(rc.z)), int(local / uint(rc.z)));
            if (splat(q, rc.w, s_shape[a], s_seed[a], s_reach[a])) ++evaluated;
        }
    }
    if (evaluated > 0u) atomicAdd(s_evaluated, evaluated);
    if (texels > shared_texels) atomicAdd(s_small_texels, texels);
    barrier();
    if (t == 0u && s_sprites > 0u) {
        atomicMax(work[0], s_level);
        atomicAdd(work[1], s_small_texels + total);
        atomicAdd(work[2], s_sprites);
        atomicAdd(work[3], s_evaluated);
    }
#endif
}
