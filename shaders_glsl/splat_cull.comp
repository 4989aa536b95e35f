#version 460
//! splat_cull — first dispatch of the `splat` pass: an occlusion bound per 8×8 tile of the depth image. A
//! sphere whose projected disc contains the tile's four corner pixel centres covers every pixel centre of the
//! tile (the disc is convex), and no pixel it covers is deeper than its centre depth + r; so the tile's final
//! depth is at most min over such spheres of (centre depth + r). `splat` then skips, per tile, spheres whose
//! nearest point (centre depth − r) is not nearer than that bound: they cannot win any atomicMin there.
//! The result is identical to splatting everything (conservative), only faster when spheres hide each other.
//! With pc.back = 1 it also writes the `iso` march's far bound per tile: the largest centre depth + r of the
//! spheres whose pixel rectangle touches the tile (no point of a sphere lies deeper, so no ray of the tile
//! leaves the last sphere later). A per-pixel farthest exit needed every sphere in the splat, which then could
//! not cull: on the worst-case workload the splat took 505 ms instead of 92.
//! In: particles. Out: tiles (r32ui, float bits, cleared to +inf), back (r32ui view, float bits, cleared to 0).
#include "common.glsl"
#include "sphere.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, set = 0, binding = 1) readonly buffer Particles { vec4 particles[]; };
layout(set = 0, binding = 2, r32ui) uniform coherent uimage2D tiles;
layout(set = 0, binding = 3, r32ui) uniform coherent uimage2D back;
layout(push_constant) uniform Push { uint count; float radius_scale; uint tile; uint back; uvec2 size; } pc;

bool inside(ivec2 px, vec3 c, float r, vec2 size, float F) {
    // A hair inside the disc, so rounding cannot make a tile pixel miss the sphere that bounds the tile.
    float a, b;
    return ray_sphere(pixel_dir(vec2(px), size, F), c, r * 0.999, a, b);
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    Particle pt = load_particle(particles[i], pc.radius_scale);
    if (pt.isolated) return;
    vec3 c = pt.c;
    float r = pt.r;
    float near = frame.proj.w;
    vec2 size = vec2(pc.size);
    float F = focal_for(size.y);
    ivec2 lo, hi;
    if (!sphere_bounds(c, r, size, F, near, lo, hi)) return;
    int T = int(pc.tile);
    if (pc.back != 0u && !over_budget(lo, hi)) {
        uint far_bits = floatBitsToUint(-c.z + r);
        for (int ty = lo.y / T; ty <= hi.y / T; ++ty)
            for (int tx = lo.x / T; tx <= hi.x / T; ++tx) imageAtomicMax(back, ivec2(tx, ty), far_bits);
    }
    if (-c.z - r <= near) return; // crosses the near plane: no occlusion bound
    uint bound = floatBitsToUint(-c.z + r);
    ivec2 last = ivec2(pc.size) - 1;
    // Tiles whose pixels all lie in [lo, hi] (edge tiles are cut by the image border).
    for (int ty = (lo.y + T - 1) / T; ty * T <= hi.y; ++ty) {
        for (int tx = (lo.x + T - 1) / T; tx * T <= hi.x; ++tx) {
            ivec2 p0 = ivec2(tx, ty) * T, p1 = min(p0 + T - 1, last);
            if (any(greaterThan(p1, hi))) continue;
            if (inside(p0, c, r, size, F) && inside(ivec2(p1.x, p0.y), c, r, size, F) &&
                inside(ivec2(p0.x, p1.y), c, r, size, F) && inside(p1, c, r, size, F)) {
                imageAtomicMin(tiles, ivec2(tx, ty), bound);
            }
        }
    }
}
