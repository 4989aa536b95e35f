//! mc_common.glsl — shared by the `mc` pass's shaders (GPU marching cubes, src/compute/mc.rs; the CPU path and
//! the reference the tests hold it to is src/field/extract/blocks.rs's block extraction). The lattice, the blocks and the
//! push constants; a block is MC_BLOCK³ cubes whose corner values are stored with a one-corner margin
//! (MC_N = MC_BLOCK + 3 corners per axis, local corner 0 = global corner c0), exactly the CPU's block layout.
//! MC_LIVE (the live mesh surface, src/surface/mesh/live.rs): the block count and the output's capacities come
//! from the device (mc_blocks.comp wrote them into the `Live` buffer at binding MC_LIVE_BINDING, which each
//! shader sets before including this), not from the host's push constants: nothing is read back.
#define MC_N (MC_BLOCK + 3u)
#define MC_NC (MC_N * MC_N * MC_N)

layout(push_constant) uniform McPush {
    vec4 lat;       // lattice origin (xyz), cube edge h (w)
    vec4 grid;      // neighbour grid origin (xyz), cell side (w, ≥ support)
    uvec4 gdims;    // neighbour grid cells per axis (xyz); w: 1 = metaball field
    ivec4 ldims;    // lattice corners per axis (xyz); w: blocks
    vec4 field;     // support, 1 / support, threshold, -
} pc;

#ifdef MC_LIVE
layout(std430, binding = MC_LIVE_BINDING) readonly buffer Live {
    uint live_blocks;     // occupied blocks (mc_blocks' count, at most the blocks buffer's capacity)
    uint live_tri_cap;    // triangles the triangle buffer holds
    uint live_vert_cap;   // vertices the position and normal buffers hold
    uint live_pad;
};
#define MC_BLOCKS live_blocks
#else
#define MC_BLOCKS uint(pc.ldims.w)
#endif

// A flat index over a 2-D dispatch (more than 65,535 work groups along x are not allowed).
uint flat_group() { return gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x; }

uint corner_index(uvec3 l) { return (l.z * MC_N + l.y) * MC_N + l.x; }
