#version 460
//! clear — one 32-bit value written into every texel of a storage image (CLEAR_F32: an r32f image, the value's
//! bits as a float; else r32ui): the passes' clears of their storage images as a compute dispatch. A transfer
//! clear (vkCmdClearColorImage) of the same images took the H100 0.24 ms at 1920×1080 for the noise atlas
//! (12.4 MB: 52 GB/s) and two layout transitions around it; a dispatch writes at the memory's rate and keeps the
//! image in the layout its readers use. Used by src/compute/clear.rs.
//! In: push constant `bits`. Out: the image (binding 0), every texel.
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
#ifdef CLEAR_F32
layout(set = 0, binding = 0, r32f) uniform writeonly image2D img;
#else
layout(set = 0, binding = 0, r32ui) uniform writeonly uimage2D img;
#endif
layout(push_constant) uniform Push { uint bits; } pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(img)))) return;
#ifdef CLEAR_F32
    imageStore(img, p, vec4(uintBitsToFloat(pc.bits)));
#else
    imageStore(img, p, uvec4(pc.bits));
#endif
}
