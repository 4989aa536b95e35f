#version 460
//! grid_count — first stage of the `grid` pass (GPU counting sort, Green 2008 "Particle simulation using
//! CUDA"): each point finds its cell and takes a slot in it with one atomic add.
//! In: points (xyz). Out: counts[cell] (cleared to 0 before), key[i] = (cell, slot within the cell).
#include "grid.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, binding = 0) readonly buffer Points { vec4 points[]; };
layout(std430, binding = 1) buffer Counts { uint counts[]; };
layout(std430, binding = 2) writeonly buffer Keys { uvec2 keys[]; };
layout(push_constant) uniform Push { GridShape g; uint n; } pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.n) return;
    uint c = grid_index(pc.g, grid_cell(pc.g, points[i].xyz));
    keys[i] = uvec2(c, atomicAdd(counts[c], 1u));
}
