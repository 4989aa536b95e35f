#version 460
//! grid_scan — exclusive prefix sum in the `grid` pass, of the totals of runs of GRID_RUN cells (grid_run_sum's
//! output; the "cells" and "counts" below are those runs and totals, and grid_run_place turns the result into
//! every cell's start), in three dispatches of this shader (mode in the push constants), Blelloch-style over
//! blocks of SCAN_BLOCK values:
//!   mode 0: each work group scans its block (4 cells per thread, then the thread sums in shared memory),
//!           writes block-local starts and the block's total into sums[block];
//!   mode 1: one work group scans sums[] in place, SCAN_BLOCK at a time with a carry;
//!   mode 2: start[c] += sums[c / SCAN_BLOCK].
//! In: counts. Out: start (the first sorted point of every cell), sums (scratch, one per block).
layout(local_size_x = SCAN_LOCAL) in;
layout(std430, binding = 0) readonly buffer Counts { uint counts[]; };
layout(std430, binding = 1) buffer Start { uint start[]; };
layout(std430, binding = 2) buffer Sums { uint sums[]; };
layout(push_constant) uniform Push { uint cells; uint blocks; uint mode; } pc;

shared uint part[SCAN_LOCAL];

// Exclusive scan of `v` over the work group (Hillis–Steele in shared memory); returns this thread's prefix,
// `total` gets the group's sum.
uint group_scan(uint v, out uint total) {
    uint t = gl_LocalInvocationID.x;
    part[t] = v;
    barrier();
    for (uint o = 1; o < SCAN_LOCAL; o <<= 1) {
        uint add = t >= o ? part[t - o] : 0u;
        barrier();
        part[t] += add;
        barrier();
    }
    total = part[SCAN_LOCAL - 1];
    uint incl = part[t];
    barrier();
    return incl - v;
}

void main() {
    uint t = gl_LocalInvocationID.x;
    if (pc.mode == 0u) {
        uint base = gl_WorkGroupID.x * SCAN_BLOCK + 4u * t;
        uint v[4];
        uint s = 0u;
        for (uint k = 0u; k < 4u; ++k) {
            uint c = base + k;
            v[k] = c < pc.cells ? counts[c] : 0u;
            s += v[k];
        }
        uint total;
        uint run = group_scan(s, total);
        for (uint k = 0u; k < 4u; ++k) {
            uint c = base + k;
            if (c < pc.cells) start[c] = run;
            run += v[k];
        }
        if (t == 0u) sums[gl_WorkGroupID.x] = total;
    } else if (pc.mode == 1u) {
        uint carry = 0u;
        for (uint b0 = 0u; b0 < pc.blocks; b0 += SCAN_BLOCK) {
            uint base = b0 + 4u * t;
            uint v[4];
            uint s = 0u;
            for (uint k = 0u; k < 4u; ++k) {
                v[k] = base + k < pc.blocks ? sums[base + k] : 0u;
                s += v[k];
            }
            uint total;
            uint run = carry + group_scan(s, total);
            for (uint k = 0u; k < 4u; ++k) {
                if (base + k < pc.blocks) sums[base + k] = run;
                run += v[k];
            }
            carry += total;
            barrier();
        }
    } else {
        uint c = gl_GlobalInvocationID.x;
        if (c < pc.cells) start[c] += sums[c / SCAN_BLOCK];
    }
}
