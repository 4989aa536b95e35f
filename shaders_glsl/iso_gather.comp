#version 460
//! iso_gather — after the `grid` pass sorted the particles on the GPU (issue #15: no CPU work per frame, so
//! GPU-resident particles such as the live simulation's work too): the iso surface's sorted points
//! (xyz, w = 0) and its cell table (first point, count), the layout iso_field.glsl reads (the CPU grid's).
//! In: particles, order, start, counts. Out: points, cells.
layout(local_size_x = LOCAL_1D) in;
layout(std430, binding = 0) readonly buffer Particles { vec4 particles[]; };
layout(std430, binding = 1) readonly buffer Order { uint order[]; };
layout(std430, binding = 2) readonly buffer Start { uint start[]; };
layout(std430, binding = 3) readonly buffer Counts { uint counts[]; };
layout(std430, binding = 4) writeonly buffer Points { vec4 points[]; };
layout(std430, binding = 5) writeonly buffer Cells { uvec2 cells[]; };
layout(push_constant) uniform Push { uint n; uint cells; } pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i < pc.n) points[i] = vec4(particles[order[i]].xyz, 0.0);
    if (i < pc.cells) cells[i] = uvec2(start[i], counts[i]);
}
