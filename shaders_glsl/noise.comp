#version 460
//! noise — the patent's noise image (NVIDIA patent US 8,947,430, eq. 15–17; method.md §8): one thread per
//! particle splats its Gaussian sprite of per-particle 3D noise (noise.glsl), weighted by how deep the particle
//! lies below the fluid surface at each pixel and scaled by its amplitude (calm, or raised while its velocity
//! changes fast), into a fixed-point accumulator (2^16 units per particle radius of height; signed values added
//! as two's-complement uints, so the sum is exact and independent of the order of the atomics).
//! In: particles (vec4 xyz + w, then one motion vec4 per particle after the `count` positions: x = id bits,
//! y = |Δv|/Δt), the fluid depth (full resolution). Out: accumulator (r32ui), cleared to 0.
#include "common.glsl"
#include "sphere.glsl"
#include "noise.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, set = 0, binding = 1) readonly buffer Particles { vec4 particles[]; };
layout(set = 0, binding = 2, r32f) uniform readonly image2D depth;
layout(set = 0, binding = 3, r32ui) uniform uimage2D accum;
layout(push_constant) uniform Push {
    uint count;
    float size;      // sprite radius in particle radii
    float freq;      // noise cycles across the sprite's radius
    float falloff;   // depth below the surface (radii) over which the weight falls by 1/e
    float calm;      // amplitude (radii of height) of a particle whose velocity changes slowly
    float turbulent; // … and of one whose velocity changes faster than the threshold
    float threshold; // velocity change (world units / s²)
} pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    Particle pt = load_particle(particles[i], 1.0);
    // Spray is drawn apart from the surface: it adds no waves to it.
    if (pt.spray) return;
    vec4 motion = particles[pc.count + i];
    float amp = noise_amplitude(motion.y, pc.calm, pc.turbulent, pc.threshold);
    vec3 o = noise_offset(floatBitsToUint(motion.x));
    vec2 size = vec2(imageSize(depth));
    float F = focal_for(size.y);
    float z = -pt.c.z;
    if (z <= frame.proj.w) return;
    float r = frame.fluid.x;
    // Sprite centre and radius in pixels (pixel_dir's convention: pixel p's centre is at p + 0.5).
    vec2 centre = vec2(0.5 * size.x + F * pt.c.x / z - 0.5, 0.5 * size.y - F * pt.c.y / z - 0.5);
    float R = F * pc.size * r / z;
    ivec2 lo = max(ivec2(ceil(centre - R)), ivec2(0));
    ivec2 hi = min(ivec2(floor(centre + R)), ivec2(size) - 1);
    if (any(greaterThan(lo, hi)) || over_budget(lo, hi)) return;
    float inv_fall = 1.0 / (pc.falloff * r);
    // Deep in the water: a particle more than DEEP falloffs (plus its sprite's radius, for a sloped surface)
    // below the surface at its centre adds nothing anywhere (exp(−16) of a radius is under 0.01 fixed-point
    // units); nor does any pixel where it lies DEEP falloffs below the surface.
    ivec2 mid = clamp(ivec2(round(centre)), ivec2(0), ivec2(size) - 1);
    float dc = imageLoad(depth, mid).x;
    if (is_fluid(dc) && z - dc > (NOISE_DEEP * pc.falloff + pc.size) * r) return;
    for (int y = lo.y; y <= hi.y; ++y) {
        for (int x = lo.x; x <= hi.x; ++x) {
            vec2 uv = (vec2(x, y) - centre) / R;
            float q = dot(uv, uv);
            if (q > 1.0) continue;
            float d = imageLoad(depth, ivec2(x, y)).x;
            if (!is_fluid(d)) continue;
            float below = (z - d) * inv_fall;
            if (below > NOISE_DEEP) continue;
            float v = amp * exp(-2.0 * q) * noise_sprite(uv, pc.freq, o) * exp(-below * below);
            int units = int(round(v * 65536.0));
            if (units != 0) imageAtomicAdd(accum, ivec2(x, y), uint(units));
        }
    }
}
