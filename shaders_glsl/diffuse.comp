#version 460
//! diffuse — draws the diffuse particles (src/diffuse/: spray, foam and bubbles after Ihmsen et al. 2012) and
//! the isolated fluid particles (low density: kept out of the surface, NVIDIA patent US 8,947,430). One thread per
//! particle splats a billboard: a capsule from x − v·s/2 to x + v·s/2 on screen (s: the shutter time, motion
//! blur), its radius the particle's (varied per particle), its coverage opacity · fade · exp(−3 q²) spread over
//! the streak (a fast particle is longer, not brighter). Foam and spray show where nothing nearer hides them:
//! in front of the background, and above the fluid surface or at most `foam_depth` below it (foam rides the
//! surface); bubbles under the surface are attenuated by the water above them, exp(−(depth below it) /
//! bubble_depth). Coverage goes into two fixed-point accumulators (4096 units per unit), exact and independent
//! of the order of the atomics; `composite` turns a sum S into opacity 1 − exp(−S), so foam thickens where it
//! gathers.
//! In: particles (the `count` fluid positions, then their motions, then the diffuse particles, two vec4 each:
//! xyz + world radius, velocity + kind (0 foam, 1 spray, 2 bubble) + fade — after a header vec4 when a GPU
//! producer appended them: dispatch groups, 1, 1, their count, the dispatch being indirect), fluid depth, scene
//! depth.
//! Out: white (foam and spray), bubbles (r32ui, cleared by the pass).
#include "common.glsl"
#include "sphere.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, set = 0, binding = 1) readonly buffer Particles { vec4 particles[]; };
layout(set = 0, binding = 2, r32f) uniform readonly image2D depth;
layout(set = 0, binding = 3, r32f) uniform readonly image2D scene_depth;
layout(set = 0, binding = 4, r32ui) uniform uimage2D white;
layout(set = 0, binding = 5, r32ui) uniform uimage2D bubbles;
layout(push_constant) uniform Push {
    uint count;         // fluid particles
    uint diffuse;       // diffuse particles after them
    uint isolated;      // 1: the fluid particles marked isolated are drawn too
    float shutter;      // seconds of motion blur
    float foam_depth;   // world units below the surface where foam still shows
    float bubble_depth; // world units of water that attenuate a bubble by 1/e
    float isolated_size; // an isolated fluid particle's billboard radius, in its own radii
    float opacity;      // coverage at a billboard's centre
    uint indirect;      // 1: the diffuse particles follow a header written on the GPU (x: groups, w: their count)
} pc;

const float UNITS = DIFFUSE_UNITS;

vec2 to_pixel(vec3 c, vec2 size, float F) {
    return vec2(0.5 * size.x + F * c.x / -c.z - 0.5, 0.5 * size.y - F * c.y / -c.z - 0.5);
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    bool header = pc.indirect != 0u;
    uint n_d = header ? min(floatBitsToUint(particles[particle_diffuse_header(pc.count)].w), pc.diffuse) : pc.diffuse;
    vec3 x;
    vec3 v;
    float rad;
    uint kind;
    float fade;
    if (i < n_d) {
        vec4 a = particles[particle_diffuse(pc.count, header, i)];
        vec4 b = particles[particle_diffuse(pc.count, header, i) + 1u];
        x = a.xyz;
        rad = a.w;
        v = b.xyz;
        float k = floor(b.w);
        kind = uint(k);
        fade = b.w - k;
        // An empty slot of the live simulation's pool.
        if (fade <= 0.0) return;
    } else {
        uint j = i - n_d;
        if (pc.isolated == 0u || j >= pc.count) return;
        vec4 pr = particles[j];
        if (pr.w >= 0.0) return;
        x = pr.xyz;
        float own = abs(pr.w);
        rad = (own > 1e-30 ? own : frame.fluid.x) * pc.isolated_size;
        v = vec3(0.0);
        kind = 1u;
        fade = 1.0;
    }
    vec2 size = vec2(imageSize(depth));
    float F = focal_for(size.y);
    vec3 c0 = (frame.view * vec4(x - 0.5 * pc.shutter * v, 1.0)).xyz;
    vec3 c1 = (frame.view * vec4(x + 0.5 * pc.shutter * v, 1.0)).xyz;
    float near = frame.proj.w;
    if (-c0.z <= near || -c1.z <= near) return;
    vec2 p0 = to_pixel(c0, size, F);
    vec2 p1 = to_pixel(c1, size, F);
    float z = 0.5 * (-c0.z - c1.z);
    // At least a pixel wide, so distant particles do not vanish between pixel centres.
    float R = max(F * rad / z, 0.75);
    vec2 seg = p1 - p0;
    float len2 = dot(seg, seg);
    float len = sqrt(len2);
    ivec2 lo = max(ivec2(ceil(min(p0, p1) - R)), ivec2(0));
    ivec2 hi = min(ivec2(floor(max(p0, p1) + R)), ivec2(size) - 1);
    if (any(greaterThan(lo, hi)) || over_budget(lo, hi)) return;
    float w0 = pc.opacity * fade * R / (R + len);
    for (int py = lo.y; py <= hi.y; ++py) {
        for (int px = lo.x; px <= hi.x; ++px) {
            vec2 p = vec2(px, py);
            float t = len2 > 1e-6 ? clamp(dot(p - p0, seg) / len2, 0.0, 1.0) : 0.5;
            vec2 d = p - (p0 + t * seg);
            float q = dot(d, d) / (R * R);
            if (q > 1.0) continue;
            float zp = mix(-c0.z, -c1.z, t);
            if (zp > imageLoad(scene_depth, ivec2(px, py)).x) continue;
            float fd = imageLoad(depth, ivec2(px, py)).x;
            float w = w0 * exp(-3.0 * q);
            bool under = is_fluid(fd) && zp > fd;
            if (kind == DIFFUSE_BUBBLE && under) {
                w *= exp(-(zp - fd) / pc.bubble_depth);
                uint units = uint(round(w * UNITS));
                if (units != 0u) imageAtomicAdd(bubbles, ivec2(px, py), units);
            } else {
                if (under && zp > fd + pc.foam_depth) continue;
                uint units = uint(round(w * UNITS));
                if (units != 0u) imageAtomicAdd(white, ivec2(px, py), units);
            }
        }
    }
}
