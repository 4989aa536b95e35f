#version 460
//! noise_scan — the tiled noise splat's list starts: an exclusive prefix sum of the n tile counts, by one work
//! group (each thread sums a run of consecutive tiles, the runs' sums are scanned in shared memory, then each
//! thread writes its run's starts); each tile's fill cursor starts at its start. Blelloch-style two-level scan.
//! In/out: tiles ([0, n) counts → [n, 2n) starts, [2n, 3n) cursors).
layout(local_size_x = 1024) in;
layout(std430, set = 0, binding = 0) buffer Tiles { uint tiles[]; };
layout(push_constant) uniform Push {
    uint count;
    float size;
    float freq;
    float falloff;
    float calm;
    float turbulent;
    float threshold;
    uint tiles;      // n
    uint small;      // sprites of at most this many texels are not binned (noise_bin)
} pc;

shared uint s_sum[1024];

void main() {
    uint t = gl_LocalInvocationID.x;
    uint n = pc.tiles;
    uint run = (n + 1023u) / 1024u;
    uint a = min(t * run, n), b = min(a + run, n);
    uint sum = 0u;
    for (uint k = a; k < b; ++k) sum += tiles[k];
    s_sum[t] = sum;
    barrier();
    for (uint off = 1u; off < 1024u; off <<= 1) {
        uint add = t >= off ? s_sum[t - off] : 0u;
        barrier();
        s_sum[t] += add;
        barrier();
    }
    uint start = s_sum[t] - sum;
    for (uint k = a; k < b; ++k) {
        tiles[n + k] = start;
        tiles[2u * n + k] = start;
        start += tiles[k];
    }
}
