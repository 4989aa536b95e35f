#version 460
//! overlay — blends the demo's text overlay (rasterised on the CPU with the font8x8 glyphs, uploaded as an
//! rgba8 image) over the final image at the top-left corner: alpha blending, straight alpha.
//! In: overlay (rgba8, sampled 1:1). Out: final (rgba8, read-modify-write).
#include "common.glsl"
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
layout(set = 0, binding = 1, rgba8) uniform readonly image2D overlay;
layout(set = 0, binding = 2, rgba8) uniform image2D out_color;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(overlay))) || any(greaterThanEqual(p, imageSize(out_color)))) return;
    vec4 o = imageLoad(overlay, p);
    if (o.a <= 0.0) return;
    vec4 c = imageLoad(out_color, p);
    imageStore(out_color, p, vec4(mix(c.rgb, o.rgb, o.a), 1.0));
}
