#version 460
//! view — debug views of the pipeline's buffers for the demo (`meniscus demo`, keys 1–7): replaces the final
//! image with one buffer mapped to colour. Modes: 1 raw depth, 2 smoothed depth (grey, near = bright, between
//! `d_min` and `d_max`), 3 thickness (heat), 4 normals (n·0.5 + 0.5, view space), 5 SSR hits (the reflected
//! scene colour, black on a miss), 6 scene colour only (the backdrop of the particle view).
//! In: the frame's images (any resolution: sampled by scaled pixel coordinates). Out: final (rgba8).
#include "common.glsl"
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
layout(set = 0, binding = 1, r32f) uniform readonly image2D raw_depth;
layout(set = 0, binding = 2, r32f) uniform readonly image2D smoothed;
layout(set = 0, binding = 3) uniform sampler2D thickness;
layout(set = 0, binding = 4, r32ui) uniform readonly uimage2D normals;
layout(set = 0, binding = 5, r32ui) uniform readonly uimage2D ssr;
layout(set = 0, binding = 6) uniform sampler2D scene_color;
layout(set = 0, binding = 7, rgba8) uniform writeonly image2D out_color;
layout(push_constant) uniform Push { int mode; float d_min; float d_max; float t_max; } pc;

vec3 heat(float t) {
    t = clamp(t, 0.0, 1.0);
    return clamp(vec3(1.5 * t, 1.5 * t - 0.5, 3.0 * t - 2.0), 0.0, 1.0) * (0.25 + 0.75 * step(1e-6, t)) + vec3(0.0, 0.0, 0.15 * (1.0 - step(1e-6, t)));
}

ivec2 scaled(ivec2 p, ivec2 from, ivec2 to) { return min(ivec2((vec2(p) + 0.5) * vec2(to) / vec2(from)), to - 1); }

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(out_color);
    if (any(greaterThanEqual(p, size))) return;
    vec2 uv = (vec2(p) + 0.5) / vec2(size);
    vec3 c = vec3(0.0);
    if (pc.mode == 1 || pc.mode == 2) {
        float d = pc.mode == 1 ? imageLoad(raw_depth, scaled(p, size, imageSize(raw_depth))).x
                               : imageLoad(smoothed, scaled(p, size, imageSize(smoothed))).x;
        c = is_fluid(d) ? vec3(1.0 - clamp((d - pc.d_min) / max(pc.d_max - pc.d_min, 1e-6), 0.0, 1.0) * 0.85) : vec3(0.05, 0.05, 0.1);
    } else if (pc.mode == 3) {
        c = heat(texture(thickness, uv).x / max(pc.t_max, 1e-6));
    } else if (pc.mode == 4) {
        uint u = imageLoad(normals, p).x;
        c = u == 0u ? vec3(0.0) : unpack_normal(u) * 0.5 + 0.5;
    } else if (pc.mode == 5) {
        uint h = imageLoad(ssr, p).x;
        c = h == SSR_MISS ? vec3(0.0) : pow(clamp(texture(scene_color, unpackUnorm2x16(h)).rgb, 0.0, 1.0), vec3(1.0 / 2.2));
    } else {
        c = pow(clamp(texture(scene_color, uv).rgb, 0.0, 1.0), vec3(1.0 / 2.2));
    }
    imageStore(out_color, p, vec4(c, 1.0));
}
