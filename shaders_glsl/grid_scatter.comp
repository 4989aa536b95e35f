#version 460
//! grid_scatter — last stage of the `grid` pass: every point writes its index at its sorted place,
//! order[start[cell] + slot] = i.
//! In: keys (cell, slot), start. Out: order (sorted place → point index).
layout(local_size_x = LOCAL_1D) in;
// Read as texels: on lavapipe a storage-buffer load at a per-lane index is a loop over the lanes per component.
layout(binding = 0) uniform usamplerBuffer keys;
layout(binding = 1) uniform usamplerBuffer start;
layout(std430, binding = 2) writeonly buffer Order { uint order[]; };
layout(push_constant) uniform Push { uint n; } pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.n) return;
    uvec2 k = texelFetch(keys, int(i)).xy;
    order[texelFetch(start, int(k.x)).x + k.y] = i;
}
