#version 460
//! grid_scatter — last stage of the `grid` pass: every point writes its index at its sorted place,
//! order[start[cell] + slot] = i.
//! In: keys (cell, slot), start. Out: order (sorted place → point index).
layout(local_size_x = LOCAL_1D) in;
layout(std430, binding = 0) readonly buffer Keys { uvec2 keys[]; };
layout(std430, binding = 1) readonly buffer Start { uint start[]; };
layout(std430, binding = 2) writeonly buffer Order { uint order[]; };
layout(push_constant) uniform Push { uint n; } pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.n) return;
    uvec2 k = keys[i];
    order[start[k.x] + k.y] = i;
}
