#version 460
//! splat — nearest linear eye depth of all particles (van der Laan et al. 2009; Moritz §3.2.1), as a COMPUTE
//! splat: one thread per particle walks the pixels its sphere covers and keeps the minimum with a 32-bit
//! atomicMin on the float's bits (positive floats order like their bit patterns; Schütz et al. 2021).
//! No gl_FragDepth, so no early-Z to lose, and no fragment-shader arithmetic (slow on some GPUs).
//! Pixels are walked tile by tile (8×8); with pc.cull a tile is skipped when `splat_cull`'s occlusion bound
//! proves the sphere hidden there (a software Hi-Z test; the output is unchanged).
//! In:  particles (vec4: world xyz, w: radius, 0 = frame radius, < 0 = isolated: not part of the surface).
//! Out: depth (R32 image viewed as r32ui), cleared to +inf; the near plane clamps (Moritz eq. 3.5).
//!      back (same layout, cleared to 0), only when pc.back = 1: the FARTHEST exit depth of the spheres, where
//!      the `iso` march can stop. It needs every sphere, so with culling (large spheres) the far bound is per
//!      tile instead, from `splat_cull` (worst-case workload: splat 505 → 81 ms).
//!      work: the sphere–pixel tests, spheres drawn and tiles skipped (binding 6, zeroed by the host).
//! With pc.ellipsoid = 1 (`--kernel anisotropic` on spheres) the particles are the iso grid's sorted points and
//! each is drawn as its anisotropic kernel's ellipsoid (binding 4, the `anisotropy` pass; Yu & Turk 2013):
//! {x : |M (x − c)| ≤ R ∛det M}, the volume of the sphere of radius R it replaces; exact ray–ellipsoid depth.
#include "common.glsl"
#include "sphere.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, set = 0, binding = 1) readonly buffer Particles { vec4 particles[]; };
layout(set = 0, binding = 2, r32ui) uniform coherent uimage2D depth_bits;
// Occlusion bound per tile from `splat_cull` (float bits); used when pc.cull = 1.
layout(set = 0, binding = 3, r32ui) uniform readonly uimage2D tiles;
layout(std430, set = 0, binding = 4) readonly buffer Aniso { vec4 aniso[]; };
layout(set = 0, binding = 5, r32ui) uniform coherent uimage2D back_bits;
// The pass's work (bench's `splat_work`), zeroed by the host: [0] sphere–pixel tests (ray–sphere or ray–ellipsoid
// intersections), [1] spheres drawn (on screen, not culled whole), [2] 8×8 tiles the occlusion bound skipped.
layout(std430, set = 0, binding = 6) buffer SplatWork { uint splat_work[4]; };
#include "work_count.glsl"
layout(push_constant) uniform Push {
    uint count;
    float radius_scale;
    uint cull;
    uint tile;
    uint ellipsoid; // 1: draw each particle's anisotropic kernel (then no cull)
    float stretch;  // the kernels' longest axis relative to ∛det M (bounds the screen rectangle)
    uint back;      // 1: also the farthest exit per pixel (never with cull)
} pc;

mat3 ell_m;      // the ellipsoid's matrix in view space (pc.ellipsoid = 1)
float ell_rho;   // and its size

/// Nearest entry (atomicMin) of the sphere (or ellipsoid) at pixel q and, with pc.back, its farthest exit.
void splat_pixel(ivec2 q, vec3 c, float r, vec2 size, float F, float near) {
    float d_in, d_out;
    vec3 dir = pixel_dir(vec2(q), size, F);
    bool hit = pc.ellipsoid != 0u ? ray_ellipsoid(dir, c, ell_m, ell_rho, d_in, d_out) : ray_sphere(dir, c, r, d_in, d_out);
    if (!hit) return;
    if (d_out < near) return;
    // An atomic only where it can change the pixel (the values only ever decrease / increase, so a plain load
    // that already beats this sphere proves the atomic a no-op): lavapipe runs an image atomic lane by lane.
    uint din = floatBitsToUint(max(d_in, near));
    if (imageLoad(depth_bits, q).x > din) imageAtomicMin(depth_bits, q, din);
    uint dout = floatBitsToUint(d_out);
    if (pc.back != 0u && imageLoad(back_bits, q).x < dout) imageAtomicMax(back_bits, q, dout);
}

/// Sphere i drawn; its work: (sphere–pixel tests, tiles skipped).
uvec2 splat_sphere(uint i) {
    // The depth splat may use a larger sphere than the particle (radius_scale): SPH surfaces lie about half a
    // radius outside the particle centres' spheres, and the larger spheres close gaps between particles.
    Particle pt = load_particle(particles[i], pc.radius_scale);
    if (pt.isolated) return uvec2(0u);
    vec3 c = pt.c;
    float r = pt.r;
    if (pc.ellipsoid != 0u) {
        load_ellipsoid(aniso[3u * i], aniso[3u * i + 1u], aniso[3u * i + 2u], r, pc.stretch, c, ell_m, ell_rho, r);
    }
    vec2 size = vec2(imageSize(depth_bits));
    float F = focal_for(size.y);
    float near = frame.proj.w;
    ivec2 lo, hi;
    if (!sphere_bounds(c, r, size, F, near, lo, hi)) return uvec2(0u);
    // Bound the work of one thread (a sphere swallowing the camera); such a sphere is clipped, not dropped.
    if (over_budget(lo, hi)) return uvec2(0u);
    if (pc.cull == 0u) {
        for (int y = lo.y; y <= hi.y; ++y) {
            for (int x = lo.x; x <= hi.x; ++x) splat_pixel(ivec2(x, y), c, r, size, F, near);
        }
        return uvec2(uint(hi.x - lo.x + 1) * uint(hi.y - lo.y + 1), 0u);
    }
    int T = int(pc.tile);
    uint nearest = floatBitsToUint(max(-c.z - r, near));
    uint tests = 0u, skipped = 0u;
    for (int ty = lo.y / T; ty <= hi.y / T; ++ty) {
        for (int tx = lo.x / T; tx <= hi.x / T; ++tx) {
            // Hidden in this whole tile: every pixel already ends at or before the bound.
            if (nearest >= imageLoad(tiles, ivec2(tx, ty)).x) {
                ++skipped;
                continue;
            }
            ivec2 a = max(lo, ivec2(tx, ty) * T), b = min(hi, ivec2(tx, ty) * T + T - 1);
            for (int y = a.y; y <= b.y; ++y) {
                for (int x = a.x; x <= b.x; ++x) splat_pixel(ivec2(x, y), c, r, size, F, near);
            }
            tests += uint(b.x - a.x + 1) * uint(b.y - a.y + 1);
        }
    }
    return uvec2(tests, skipped);
}

// The work group's counts, added to the pass's with one atomic each per group: an atomic per thread on the
// global counters cost the splat 10–15 % on lavapipe (two cores contending for one cache line).
shared uint s_work[3];

void main() {
    if (gl_LocalInvocationIndex < 3u) s_work[gl_LocalInvocationIndex] = 0u;
    barrier();
    uint i = gl_GlobalInvocationID.x;
    uvec2 w = i < pc.count ? splat_sphere(i) : uvec2(0u);
    // Counted only in a frame that asks (work_count.glsl's WORK_COUNTING).
    if (!WORK_COUNTING) w = uvec2(0u);
    if (w.x > 0u) {
        atomicAdd(s_work[0], w.x);
        atomicAdd(s_work[1], 1u);
    }
    if (w.y > 0u) atomicAdd(s_work[2], w.y);
    barrier();
    if (gl_LocalInvocationIndex < 3u && s_work[gl_LocalInvocationIndex] > 0u)
        atomicAdd(splat_work[gl_LocalInvocationIndex], s_work[gl_LocalInvocationIndex]);
}
