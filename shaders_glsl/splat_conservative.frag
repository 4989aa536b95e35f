#version 460
//! splat_conservative (fragment) — as splat_fragdepth, but declares depth_less: the written depth never
//! exceeds the quad's (reversed Z, GREATER test), so the early depth test stays valid.
//! In: the sphere (view centre, radius) from the vertex stage. Out: linear eye depth (R32F colour).
#include "common.glsl"
#include "sphere.glsl"
#include "splat_raster.glsl"
layout(depth_less) out float gl_FragDepth;
layout(location = 0) flat in vec4 v_sphere;
layout(location = 0) out float out_depth;

void main() {
    float F = focal_for(pc.size.y);
    float near = frame.proj.w;
    float d_in, d_out;
    if (!ray_sphere(pixel_dir(floor(gl_FragCoord.xy), pc.size, F), v_sphere.xyz, v_sphere.w, d_in, d_out) || d_out < near) discard;
    float d = max(d_in, near);
    out_depth = d;
    gl_FragDepth = near / d;
}
