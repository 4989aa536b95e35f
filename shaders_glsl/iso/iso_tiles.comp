#version 460
//! iso_tiles — the LOCAL_2D × LOCAL_2D tiles of the bound spheres' depth that hold fluid, listed for the `iso`
//! cast's first dispatch (iso_cast.glsl), which then runs one work group per listed tile instead of one per tile
//! of the screen. Why: lavapipe runs a work group's invocations as SIMD lanes and an early return as masked
//! lanes, so every vector of pixels without fluid paid for the whole march — at 960×540 the cast cost 56–66 ms
//! with every invocation returning at once, against 97 ms marching (the shared 59k dam break frame 20 at the
//! reference camera, where a tenth of the screen holds fluid; docs/iso-surface.md). One work group per tile: a
//! subgroup vote, one atomic per tile that holds fluid.
//! In: depth (R32F, linear eye depth; common.glsl's `is_fluid`). Out: the tiles (x | y << 16, in tiles); the cast's
//! indirect dispatch at iso_args[16 … 18], rows of ISO_TILE_ROW work groups (x: up to ISO_TILE_ROW, y: the rows,
//! z: 1), and the count of tiles at [19]; the host zeroes the header.
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_vote : require
#include "common.glsl"
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
layout(set = 0, binding = 1, r32f) uniform readonly image2D depth;
layout(std430, set = 0, binding = 2) buffer IsoArgs { uint iso_args[20]; };
layout(std430, set = 0, binding = 3) writeonly buffer IsoTiles { uint iso_tiles[]; };

shared uint fluid;

void main() {
    if (gl_LocalInvocationIndex == 0u) fluid = 0u;
    barrier();
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    bool here = all(lessThan(p, imageSize(depth))) && is_fluid(imageLoad(depth, p).x);
    if (subgroupAny(here) && subgroupElect()) atomicOr(fluid, 1u);
    barrier();
    if (gl_LocalInvocationIndex == 0u) {
        if (fluid != 0u) {
            uint at = atomicAdd(iso_args[19], 1u);
            iso_tiles[at] = gl_WorkGroupID.x | (gl_WorkGroupID.y << 16);
            if (at < ISO_TILE_ROW) atomicAdd(iso_args[16], 1u);
            if (at % ISO_TILE_ROW == 0u) atomicAdd(iso_args[17], 1u);
        }
        if (gl_WorkGroupID.xy == uvec2(0)) iso_args[18] = 1u;
    }
}
