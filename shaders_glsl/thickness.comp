#version 460
//! thickness — additive fluid thickness (Moritz eq. 3.6, T = 2·r·n_z per sphere), at reduced resolution.
//! Compute splat: one thread per particle adds the exact chord of each covered pixel's view ray through its
//! sphere, cut at the scene depth, so particles behind scene geometry add nothing. Fixed-point uint atomics
//! (frame.fluid.z units per world unit) keep it portable (no float-atomic extension needed).
//! With pc.ellipsoid = 1 (`--kernel anisotropic` on spheres) the particles are the iso grid's sorted points and
//! each adds the chord through its anisotropic kernel's ellipsoid of the particle's volume (binding 4, as in
//! splat.comp; Yu & Turk 2013).
//! In: particles, scene depth (full-res r32f). Out: thickness accumulator (r32ui), cleared to 0.
#include "common.glsl"
#include "sphere.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, set = 0, binding = 1) readonly buffer Particles { vec4 particles[]; };
layout(set = 0, binding = 2, r32f) uniform readonly image2D scene_depth;
layout(set = 0, binding = 3, r32ui) uniform uimage2D accum;
layout(std430, set = 0, binding = 4) readonly buffer Aniso { vec4 aniso[]; };
layout(push_constant) uniform Push { uint count; uint ellipsoid; float stretch; } pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    // Isolated particles still add thickness.
    Particle pt = load_particle(particles[i], 1.0);
    vec3 c = pt.c;
    float r = pt.r;
    mat3 ell_m = mat3(1.0);
    float ell_rho = r;
    if (pc.ellipsoid != 0u) {
        load_ellipsoid(aniso[3u * i], aniso[3u * i + 1u], aniso[3u * i + 2u], r, pc.stretch, c, ell_m, ell_rho, r);
    }
    vec2 size = vec2(imageSize(accum));
    vec2 scene_size = vec2(imageSize(scene_depth));
    float F = focal_for(size.y);
    float near = frame.proj.w;
    ivec2 lo, hi;
    if (!sphere_bounds(c, r, size, F, near, lo, hi)) return;
    if (over_budget(lo, hi)) return;
    vec2 to_scene = scene_size / size;
    for (int y = lo.y; y <= hi.y; ++y) {
        for (int x = lo.x; x <= hi.x; ++x) {
            vec3 dir = pixel_dir(vec2(x, y), size, F);
            float d_in, d_out;
            bool hit = pc.ellipsoid != 0u ? ray_ellipsoid(dir, c, ell_m, ell_rho, d_in, d_out)
                                          : ray_sphere(dir, c, r, d_in, d_out);
            if (!hit) continue;
            ivec2 sp = min(ivec2((vec2(x, y) + 0.5) * to_scene), ivec2(scene_size) - 1);
            float scene = imageLoad(scene_depth, sp).x;
            d_in = max(d_in, near);
            d_out = min(d_out, scene);
            if (d_out <= d_in) continue;
            // Chord length along the ray: depth difference times the ray's length per unit depth.
            float chord = (d_out - d_in) * length(dir);
            uint units = uint(chord * frame.fluid.z + 0.5);
            if (units > 0u) imageAtomicAdd(accum, ivec2(x, y), units);
        }
    }
}
