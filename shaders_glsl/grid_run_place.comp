#version 460
//! grid_run_place — last stage of the `grid` pass's prefix sum: each thread walks its run of GRID_RUN cells from
//! the run's first place (grid_scan's exclusive sum of the run totals) and writes every cell's first place.
//! In: counts (texels), run_start. Out: start[c] = Σ counts[c'] over c' < c.
layout(local_size_x = LOCAL_1D) in;
layout(binding = 0) uniform usamplerBuffer counts;
layout(std430, binding = 1) readonly buffer RunStart { uint run_start[]; };
layout(std430, binding = 2) writeonly buffer Start { uint start[]; };
layout(push_constant) uniform Push { uint cells; } pc;

void main() {
    uint r = gl_GlobalInvocationID.x;
    uint c0 = r * GRID_RUN;
    if (c0 >= pc.cells) return;
    uint c1 = min(c0 + GRID_RUN, pc.cells);
    uint run = run_start[r];
    for (uint c = c0; c < c1; ++c) {
        start[c] = run;
        run += texelFetch(counts, int(c)).x;
    }
}
