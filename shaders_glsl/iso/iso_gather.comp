#version 460
//! iso_gather — after the `grid` pass sorted the particles on the GPU (issue #15: no CPU work per frame, so
//! GPU-resident particles such as the live simulation's work too): the iso surface's sorted points
//! (xyz, w = 0) and its cell table (first point, count), the layout iso_field.glsl reads (the CPU grid's).
//! Within a cell the points are placed by particle index, not in the order the `grid` pass's atomics gave
//! them: the field's weights and sums run over a cell in this order, so the surface is the same bytes on
//! every run (a sequence renders frame k identically however it is split). A cell of more than RANK_MAX
//! points keeps the atomics' order (its rank would cost a scan of the cell per point).
//! In: particles, order, start, counts, keys (cell, atomic slot per particle). Out: points, cells.
layout(local_size_x = LOCAL_1D) in;
layout(std430, binding = 0) readonly buffer Particles { vec4 particles[]; };
layout(std430, binding = 1) readonly buffer Order { uint order[]; };
layout(std430, binding = 2) readonly buffer Start { uint start[]; };
layout(std430, binding = 3) readonly buffer Counts { uint counts[]; };
layout(std430, binding = 4) readonly buffer Keys { uvec2 keys[]; };
layout(std430, binding = 5) writeonly buffer Points { vec4 points[]; };
layout(std430, binding = 6) writeonly buffer Cells { uvec2 cells[]; };
layout(push_constant) uniform Push { uint n; uint cells; } pc;

const uint RANK_MAX = 256u;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i < pc.n) {
        // Particle i goes to its cell's range at its rank by particle index among the cell's members.
        uvec2 k = keys[i];
        uint s = start[k.x];
        uint count = counts[k.x];
        uint place = s + k.y;
        if (count <= RANK_MAX) {
            uint rank = 0u;
            for (uint j = s; j < s + count; ++j) {
                rank += uint(order[j] < i);
            }
            place = s + rank;
        }
        points[place] = vec4(particles[i].xyz, 0.0);
    }
    if (i < pc.cells) cells[i] = uvec2(start[i], counts[i]);
}
