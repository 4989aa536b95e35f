#version 460
//! grid_run_sum — second stage of the `grid` pass: the cell counts summed over runs of GRID_RUN consecutive
//! cells, one run per thread, so the prefix sum that follows (grid_scan) works on GRID_RUN times fewer values.
//! Why: grid_scan's work groups share memory across barriers, which lavapipe runs as one coroutine per 8 lanes
//! (created and switched per work group), and that, not the arithmetic, was most of the pass: scanning every
//! cell took 15 of the 59k dam break's 17 ms (docs/simulation.md, commit 434fdd1). This stage and grid_run_place have no
//! barriers; a GPU reads the runs through its caches.
//! In: counts (texels). Out: run_counts[r] = Σ counts over cells [r·GRID_RUN, (r + 1)·GRID_RUN).
layout(local_size_x = LOCAL_1D) in;
layout(binding = 0) uniform usamplerBuffer counts;
layout(std430, binding = 1) writeonly buffer RunCounts { uint run_counts[]; };
layout(push_constant) uniform Push { uint cells; } pc;

void main() {
    uint r = gl_GlobalInvocationID.x;
    uint c0 = r * GRID_RUN;
    if (c0 >= pc.cells) return;
    uint c1 = min(c0 + GRID_RUN, pc.cells);
    uint s = 0u;
    for (uint c = c0; c < c1; ++c) s += texelFetch(counts, int(c)).x;
    run_counts[r] = s;
}
