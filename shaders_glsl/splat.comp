#version 460
//! splat — nearest linear eye depth of all particles (van der Laan et al. 2009; Moritz §3.2.1), as a COMPUTE
//! splat: one thread per particle walks the pixels its sphere covers and keeps the minimum with a 32-bit
//! atomicMin on the float's bits (positive floats order like their bit patterns; Schütz et al. 2021). Where
//! spheres are large (pc.lanes > 1), pc.lanes consecutive invocations share a sphere, each taking every
//! lanes-th pixel, so a GPU's warp is not held by one thread's long walk; the dispatch is then 2D (rows of
//! pc.row invocations) and the depth is the same.
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
    uint lanes;     // consecutive invocations per sphere (1: one thread walks its pixels)
    uint row;       // invocations per row of the dispatch grid (the linear index spans rows)
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

/// Sphere i drawn by lane `lane` of its `pc.lanes` (each takes every lanes-th pixel of the sphere's rectangle,
/// tile by tile with the cull); its work: (sphere–pixel tests, tiles skipped, drawn) — tiles and drawn counted
/// by lane 0 alone.
uvec3 splat_sphere(uint i, uint lane) {
    // The depth splat may use a larger sphere than the particle (radius_scale): SPH surfaces lie about half a
    // radius outside the particle centres' spheres, and the larger spheres close gaps between particles.
    Particle pt = load_particle(particles[i], pc.radius_scale);
    if (pt.isolated) return uvec3(0u);
    vec3 c = pt.c;
    float r = pt.r;
    if (pc.ellipsoid != 0u) {
        load_ellipsoid(aniso[3u * i], aniso[3u * i + 1u], aniso[3u * i + 2u], r, pc.stretch, c, ell_m, ell_rho, r);
    }
    vec2 size = vec2(imageSize(depth_bits));
    float F = focal_for(size.y);
    float near = frame.proj.w;
    ivec2 lo, hi;
    if (!sphere_bounds(c, r, size, F, near, lo, hi)) return uvec3(0u);
    // Bound the work of one thread (a sphere swallowing the camera); such a sphere is clipped, not dropped.
    if (over_budget(lo, hi)) return uvec3(0u);
    uint L = max(pc.lanes, 1u);
    if (pc.cull == 0u) {
        uint w = uint(hi.x - lo.x + 1), n = w * uint(hi.y - lo.y + 1);
        uint tests = 0u;
        for (uint k = lane; k < n; k += L) {
            splat_pixel(lo + ivec2(k % w, k / w), c, r, size, F, near);
            ++tests;
        }
        return uvec3(tests, 0u, lane == 0u && n > 0u ? 1u : 0u);
    }
    int T = int(pc.tile);
    uint nearest = floatBitsToUint(max(-c.z - r, near));
    uint tests = 0u, skipped = 0u;
    bool drawn = false;
    for (int ty = lo.y / T; ty <= hi.y / T; ++ty) {
        for (int tx = lo.x / T; tx <= hi.x / T; ++tx) {
            // Hidden in this whole tile: every pixel already ends at or before the bound.
            if (nearest >= imageLoad(tiles, ivec2(tx, ty)).x) {
                ++skipped;
                continue;
            }
            ivec2 a = max(lo, ivec2(tx, ty) * T), b = min(hi, ivec2(tx, ty) * T + T - 1);
            uint w = uint(b.x - a.x + 1), n = w * uint(b.y - a.y + 1);
            for (uint k = lane; k < n; k += L) {
                splat_pixel(a + ivec2(k % w, k / w), c, r, size, F, near);
                ++tests;
            }
            drawn = true;
        }
    }
    return uvec3(tests, lane == 0u ? skipped : 0u, lane == 0u && drawn ? 1u : 0u);
}

// The work group's counts, added to the pass's with one atomic each per group: an atomic per thread on the
// global counters cost the splat 10–15 % on lavapipe (two cores contending for one cache line).
shared uint s_work[3];

void main() {
    if (gl_LocalInvocationIndex < 3u) s_work[gl_LocalInvocationIndex] = 0u;
    barrier();
    uint g = gl_GlobalInvocationID.y * pc.row + gl_GlobalInvocationID.x;
    uint L = max(pc.lanes, 1u);
    uint i = g / L;
    uvec3 w = i < pc.count ? splat_sphere(i, g % L) : uvec3(0u);
    // Counted only in a frame that asks (work_count.glsl's WORK_COUNTING).
    if (!WORK_COUNTING) w = uvec3(0u);
    if (w.x > 0u) atomicAdd(s_work[0], w.x);
    if (w.z > 0u) atomicAdd(s_work[1], 1u);
    if (w.y > 0u) atomicAdd(s_work[2], w.y);
    barrier();
    if (gl_LocalInvocationIndex < 3u && s_work[gl_LocalInvocationIndex] > 0u)
        atomicAdd(splat_work[gl_LocalInvocationIndex], s_work[gl_LocalInvocationIndex]);
}
