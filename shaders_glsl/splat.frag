#version 460
//! splat (fragment) — the rasterised splat variants' fragment shader, one source compiled three times by
//! build.rs (VARIANTS): exact ray–sphere depth of the pixel's ray (as the compute splat), output as linear eye
//! depth (R32F colour), and
//! * FRAG_DEPTH: reversed-Z `near / d` written to gl_FragDepth (disables the early depth test);
//! * CONSERVATIVE_DEPTH: the same, declared depth_less — the written depth never exceeds the quad's (reversed Z,
//!   GREATER test), so the early depth test stays valid;
//! * MIN_BLEND: no depth buffer; the linear depth is MIN-blended into the target (Wumpf/blub).
//! In: the sphere (view centre, radius) from the vertex stage. See splat_raster.glsl.
#include "common.glsl"
#include "sphere.glsl"
#include "splat_raster.glsl"
#ifdef CONSERVATIVE_DEPTH
layout(depth_less) out float gl_FragDepth;
#endif
layout(location = 0) flat in vec4 v_sphere;
layout(location = 0) out float out_depth;

void main() {
    float F = focal_for(pc.size.y);
    float near = frame.proj.w;
    float d_in, d_out;
    if (!ray_sphere(pixel_dir(floor(gl_FragCoord.xy), pc.size, F), v_sphere.xyz, v_sphere.w, d_in, d_out) || d_out < near) discard;
    float d = max(d_in, near);
    out_depth = d;
#ifndef MIN_BLEND
    gl_FragDepth = near / d;
#endif
}
