#version 460
//! sim_dfsph_check — the convergence test of a DFSPH solve, on the GPU so that no iteration waits for the host:
//! the work groups' error partials (sim_dfsph_rate) summed, the average error compared with the bound η, and
//! the next iteration's indirect dispatch written: its work groups, or 0 once the solve has converged (average
//! error ≤ η after at least `min_iter` corrections) or used `max_iter` — later iterations' dispatches then do
//! nothing. `init` starts a solve. The statistics (per solve: corrections, last average error; per frame: the
//! sums and maxima the host reports) accumulate in `stats`.
//! In: partials. In/out: args (x: work groups, y, z: 1, w: corrections so far), stats.
#include "sim_common.glsl"
layout(local_size_x = 256) in;
layout(push_constant) uniform Check {
    uint groups;      // work groups of a per-particle dispatch
    uint init;        // 1: the solve's first evaluation
    uint min_iter;    // corrections before convergence may stop the solve
    uint max_iter;    // corrections at most
    float eta;        // the bound on the average error
    uint solve;       // 0: divergence, 1: density (stats slot)
} pc;
layout(std430, binding = 1) readonly buffer Partials { float partials[]; };
layout(std430, binding = 2) buffer Args { uint args[4]; };
// Per solve s (8 words each): [0] steps, [1] corrections (sum), [2] max corrections, [3] last error (bits),
// [4] max error (bits), [5] sum of errors (bits), [6] steps that reached max_iter.
layout(std430, binding = 3) buffer Stats { uint stats[16]; };

shared float s_sum[256];
shared bool s_done;

void main() {
    uint l = gl_LocalInvocationID.x;
    if (l == 0u) s_done = pc.init == 0u && args[0] == 0u;
    barrier();
    if (s_done) return;
    float sum = 0.0;
    for (uint g = l; g < pc.groups; g += 256u) sum += partials[g];
    s_sum[l] = sum;
    barrier();
    for (uint s = 128u; s > 0u; s >>= 1u) {
        if (l < s) s_sum[l] += s_sum[l + s];
        barrier();
    }
    if (l != 0u) return;
    float avg = s_sum[0] / float(max(sim.counts.x, 1u));
    uint done = pc.init == 1u ? 0u : args[3];
    bool stop = (avg <= pc.eta && done >= pc.min_iter) || done >= pc.max_iter;
    args[0] = stop ? 0u : pc.groups;
    args[1] = 1u;
    args[2] = 1u;
    args[3] = done + 1u;
    if (stop) {
        uint b = 8u * pc.solve;
        stats[b] += 1u;
        stats[b + 1u] += done;
        stats[b + 2u] = max(stats[b + 2u], done);
        stats[b + 3u] = floatBitsToUint(avg);
        stats[b + 4u] = floatBitsToUint(max(uintBitsToFloat(stats[b + 4u]), avg));
        stats[b + 5u] = floatBitsToUint(uintBitsToFloat(stats[b + 5u]) + avg);
        if (done >= pc.max_iter && avg > pc.eta) stats[b + 6u] += 1u;
    }
}
