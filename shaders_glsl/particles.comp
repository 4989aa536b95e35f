#version 460
//! particles — the particles themselves as lit spheres coloured by an attribute (Princisgh §2):
//! Lambert + ambient shading of the exact sphere normal, colour interpolated between two colours in HSV by the
//! particle's normalised value (speed, density or height). Runs after `splat` (compute) filled the raw depth:
//! each particle colours the pixels where its own depth is the stored minimum (bit-exact, same math).
//! In: particles, per-particle value in [0, 1], raw depth (r32ui view). Out: final (rgba8), covered pixels only.
#include "common.glsl"
#include "sphere.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, set = 0, binding = 1) readonly buffer Particles { vec4 particles[]; };
layout(std430, set = 0, binding = 2) readonly buffer Values { float values[]; };
layout(set = 0, binding = 3, r32ui) uniform readonly uimage2D depth_bits;
layout(set = 0, binding = 4, rgba8) uniform writeonly image2D out_color;
layout(push_constant) uniform Push { uint count; float radius_scale; vec2 hue; } pc; // hue: from, to (turns)

vec3 hsv2rgb(vec3 c) {
    vec3 p = abs(fract(c.xxx + vec3(1.0, 2.0 / 3.0, 1.0 / 3.0)) * 6.0 - 3.0);
    return c.z * mix(vec3(1.0), clamp(p - 1.0, 0.0, 1.0), c.y);
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) return;
    Particle pt = load_particle(particles[i], pc.radius_scale);
    if (pt.isolated) return;
    vec3 c = pt.c;
    float r = pt.r;
    vec2 size = vec2(imageSize(depth_bits));
    vec2 osize = vec2(imageSize(out_color));
    float F = focal_for(size.y);
    float near = frame.proj.w;
    ivec2 lo, hi;
    if (!sphere_bounds(c, r, size, F, near, lo, hi)) return;
    if (over_budget(lo, hi)) return;
    vec3 col = hsv2rgb(vec3(mix(pc.hue.x, pc.hue.y, clamp(values[i], 0.0, 1.0)), 0.85, 0.95));
    vec3 L = normalize(mat3(frame.view) * frame.sun.xyz);
    for (int y = lo.y; y <= hi.y; ++y) {
        for (int x = lo.x; x <= hi.x; ++x) {
            vec3 dir = pixel_dir(vec2(x, y), size, F);
            float d_in, d_out;
            if (!ray_sphere(dir, c, r, d_in, d_out) || d_out < near) continue;
            float d = max(d_in, near);
            if (imageLoad(depth_bits, ivec2(x, y)).x != floatBitsToUint(d)) continue;
            vec3 n = normalize(d * dir - c);
            vec3 shade = col * (0.3 + 0.7 * max(dot(n, L), 0.0));
            // Fluid images may be smaller than the output: fill the covered block.
            ivec2 o0 = ivec2(vec2(x, y) * osize / size), o1 = ivec2(vec2(x + 1, y + 1) * osize / size);
            for (int oy = o0.y; oy < max(o1.y, o0.y + 1); ++oy)
                for (int ox = o0.x; ox < max(o1.x, o0.x + 1); ++ox)
                    imageStore(out_color, ivec2(ox, oy), vec4(pow(shade, vec3(1.0 / 2.2)), 1.0));
        }
    }
}
