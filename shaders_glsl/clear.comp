#version 460
//! clear — one 32-bit value written into every texel of a storage image (CLEAR_F32: an r32f image, the value's
//! bits as a float; else r32ui): the passes' clears of their storage images as a compute dispatch. A transfer
//! clear (vkCmdClearColorImage) of the same images took the H100 0.24 ms at 1920×1080 for the noise atlas
//! (12.4 MB: 52 GB/s) and two layout transitions around it; a dispatch writes at the memory's rate and keeps the
//! image in the layout its readers use. Used by src/compute/clear.rs.
//! Each invocation writes CLEAR_SPAN texels of a row: a quarter of the work groups of one texel each (a 1080p
//! image is 32 k groups of 64 one-texel invocations otherwise).
//! In: push constant `bits`. Out: the image (binding 0), every texel.
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
#ifdef CLEAR_F32
layout(set = 0, binding = 0, r32f) uniform writeonly image2D img;
#else
layout(set = 0, binding = 0, r32ui) uniform writeonly uimage2D img;
#endif
layout(push_constant) uniform Push { uint bits; } pc;

void main() {
    ivec2 size = imageSize(img);
    ivec2 p = ivec2(gl_GlobalInvocationID.x * CLEAR_SPAN, gl_GlobalInvocationID.y);
    if (p.y >= size.y) return;
    for (int k = 0; k < int(CLEAR_SPAN) && p.x + k < size.x; ++k) {
#ifdef CLEAR_F32
        imageStore(img, p + ivec2(k, 0), vec4(uintBitsToFloat(pc.bits)));
#else
        imageStore(img, p + ivec2(k, 0), uvec4(pc.bits));
#endif
    }
}
