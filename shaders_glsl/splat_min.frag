#version 460
//! splat_min (fragment) — no depth buffer: linear depth is MIN-blended into the R32F target (Wumpf/blub).
//! In: the sphere (view centre, radius) from the vertex stage. Out: linear eye depth (R32F colour).
#include "common.glsl"
#include "sphere.glsl"
#include "splat_raster.glsl"

layout(location = 0) flat in vec4 v_sphere;
layout(location = 0) out float out_depth;

void main() {
    float F = focal_for(pc.size.y);
    float near = frame.proj.w;
    float d_in, d_out;
    if (!ray_sphere(pixel_dir(floor(gl_FragCoord.xy), pc.size, F), v_sphere.xyz, v_sphere.w, d_in, d_out) || d_out < near) discard;
    float d = max(d_in, near);
    out_depth = d;

}
