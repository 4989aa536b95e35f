#version 460
//! ssr — screen-space reflections of the scene in the fluid (Moritz §3.6; McGuire & Mara, JCGT 2014).
//! Per fluid pixel the view ray is reflected about the normal and marched in screen space with the
//! perspective-correct DDA: both ends are projected, the march steps along the major axis `stride` pixels at a
//! time, 1/d is interpolated linearly in screen space, and a hit is where the ray's depth interval reaches the
//! scene depth within `thickness`. After a hit with stride > 1, binary refinement halves the step back and
//! forth. No hit → alpha 0 and the composite falls back to the sky.
//! In: fluid depth (r32f), normals (r32ui), scene depth (r32f), scene colour (sampled).
//! Out: hit (r32ui: packUnorm2x16 of the hit's uv, SSR_MISS where nothing is hit) — 4 bytes a pixel; the
//! composite samples the scene colour there and fades towards the screen border.
#include "common.glsl"
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 1, r32f) uniform readonly image2D fluid_depth;
layout(set = 0, binding = 2, r32ui) uniform readonly uimage2D normals;
layout(set = 0, binding = 3, r32f) uniform readonly image2D scene_depth;
layout(set = 0, binding = 4, r32ui) uniform writeonly uimage2D ssr_out;
layout(push_constant) uniform Push {
    float stride;       // pixels per step (≥ 1)
    int max_steps;
    int refine;         // binary refinement iterations
    float max_distance; // world units along the reflected ray
    float thickness;    // world depth tolerance of a hit
} pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(ssr_out);
    if (any(greaterThanEqual(p, size))) return;
    float d0 = imageLoad(fluid_depth, p).x;
    if (!is_fluid(d0) || d0 >= imageLoad(scene_depth, p).x) {
        imageStore(ssr_out, p, uvec4(SSR_MISS));
        return;
    }
    float F = focal_for(float(size.y));
    vec2 half_size = 0.5 * vec2(size);
    vec3 P0 = d0 * pixel_dir(vec2(p), vec2(size), F);
    vec3 n = unpack_normal(imageLoad(normals, p).x);
    vec3 R = reflect(normalize(P0), n);
    // Clip the ray at the near plane.
    float len = pc.max_distance;
    float near = frame.proj.w;
    if (P0.z + R.z * len > -near) len = (-near - P0.z) / R.z;
    vec3 P1 = P0 + R * len;
    float k0 = 1.0 / -P0.z, k1 = 1.0 / -P1.z;
    vec2 S0 = half_size + F * vec2(P0.x, -P0.y) * k0 - 0.5;
    vec2 S1 = half_size + F * vec2(P1.x, -P1.y) * k1 - 0.5;
    vec2 delta = S1 - S0;
    // At least one pixel of screen movement.
    if (dot(delta, delta) < 1e-4) delta = vec2(1e-2, 0.0);
    bool permute = abs(delta.y) > abs(delta.x);
    if (permute) { delta = delta.yx; S0 = S0.yx; S1 = S1.yx; }
    float step_dir = sign(delta.x);
    float inv_dx = step_dir / delta.x;
    vec2 dS = vec2(step_dir, delta.y * inv_dx);
    float dk = (k1 - k0) * inv_dx;
    float stride = max(pc.stride, 1.0);
    vec2 S = S0;
    float k = k0;
    float prev_d = d0;
    float end_x = S1.x * step_dir;
    bool hit = false;
    vec2 hit_px = vec2(0.0);
    // Start one pixel out so the ray leaves its own surface.
    S += dS; k += dk;
    for (int i = 0; i < pc.max_steps && S.x * step_dir <= end_x; ++i) {
        S += dS * stride;
        k += dk * stride;
        vec2 px = permute ? S.yx : S;
        if (any(lessThan(px, vec2(0.0))) || any(greaterThanEqual(px, vec2(size)))) break;
        float ray_d = 1.0 / k;
        float scene = imageLoad(scene_depth, ivec2(px)).x;
        float lo = min(prev_d, ray_d), hi = max(prev_d, ray_d);
        if (scene < 1e30 && hi >= scene && lo <= scene + pc.thickness) {
            // Binary refinement between the previous sample and this one.
            float s = stride;
            for (int j = 0; j < pc.refine && s > 1.0; ++j) {
                s *= 0.5;
                vec2 Sm = S - dS * s;
                float km = k - dk * s;
                vec2 pm = permute ? Sm.yx : Sm;
                float sm = imageLoad(scene_depth, clamp(ivec2(pm), ivec2(0), size - 1)).x;
                if (1.0 / km >= sm) { S = Sm; k = km; }
            }
            hit = true;
            hit_px = permute ? S.yx : S;
            break;
        }
        prev_d = ray_d;
    }
    if (!hit) {
        imageStore(ssr_out, p, uvec4(SSR_MISS));
        return;
    }
    imageStore(ssr_out, p, uvec4(packUnorm2x16((hit_px + 0.5) / vec2(size))));
}
