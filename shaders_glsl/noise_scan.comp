#version 460
//! noise_scan — the tiled noise splat's list starts: an exclusive prefix sum of the n tile counts, by one work
//! group (each thread sums a run of consecutive tiles, the runs' sums are scanned in shared memory, then each
//! thread writes its run's starts); each tile's fill cursor starts at its start. Blelloch-style two-level scan.
//! It also writes the indirect dispatches that follow: noise_fill, one thread per binned sprite, and
//! noise_gather, one work group per tile — none when no sprite was binned (every sprite was small).
//! In/out: tiles ([0, n) counts → [n, 2n) starts, [2n, 3n) cursors). In: work[6] (sprites binned). Out: args.
layout(local_size_x = 1024) in;
layout(std430, set = 0, binding = 0) buffer Tiles { uint tiles[]; };
layout(std430, set = 0, binding = 1) readonly buffer Work { uint work[8]; };
// Two dispatches' work group counts: [0, 3) noise_fill, [3, 6) noise_gather.
layout(std430, set = 0, binding = 2) writeonly buffer Args { uint args[8]; };
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
    float lod;       // texels per cycle of the finer octave a level keeps ([noise] lod_samples)
} pc;

shared uint s_sum[1024];

void main() {
    uint t = gl_LocalInvocationID.x;
    uint n = pc.tiles;
    if (t == 0u) {
        uint b = work[6];
        args[0] = (b + uint(LOCAL_1D) - 1u) / uint(LOCAL_1D);
        args[1] = 1u;
        args[2] = 1u;
        args[3] = b > 0u ? n : 0u;
        args[4] = 1u;
        args[5] = 1u;
    }
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
