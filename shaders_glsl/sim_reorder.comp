#version 460
//! sim_reorder — after the `grid` pass sorted the predicted positions into cells: move the particles into grid
//! order, so every neighbour loop reads contiguous memory (Green 2008). Within a cell the particles are put in
//! ascending order of their index before the move, not in the order the grid's atomic adds gave them, so a
//! step is deterministic: the same start gives the same simulation, bit for bit, on one device (reproducible
//! exports and tests; the neighbour sums keep one order).
//! In: order (sorted place → particle), keys (particle → cell), start, counts (grid), state, pred.
//! Out: the same two arrays in grid order, the state's velocity with gravity's Δt·g added (sim_predict's v,
//! which that stage does not write back). Everything is read as texels (state as RGBA32UI, two per
//! particle, so the id bits pass unchanged): on lavapipe a storage-buffer load of a vector is a loop over the
//! lanes per component, a texel fetch one gather (docs/simulation.md, commits a4c867b and 434fdd1).
//! With REORDER_CARRY (SIM_REORDER_CARRY) one more float per particle moves with it: carry_in (in the state's
//! order) → carry_out (grid order) — DFSPH's divergence-free solve's last κ sum, its warm start.
#include "sim_common.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(binding = 1) uniform usamplerBuffer order;
layout(binding = 2) uniform usamplerBuffer state_in;   // read with state_x, state_v
layout(binding = 3) uniform samplerBuffer pred_in;
layout(std430, binding = 4) writeonly buffer StateOut { State state_out[]; };
layout(std430, binding = 5) writeonly buffer PredOut { vec4 pred_out[]; };
layout(binding = 6) uniform usamplerBuffer keys;     // (cell, slot) of particle i
layout(binding = 7) uniform usamplerBuffer start;
layout(binding = 8) uniform usamplerBuffer counts;
#ifdef REORDER_CARRY
layout(binding = 9) uniform samplerBuffer carry_in;
layout(std430, binding = 10) writeonly buffer CarryOut { float carry_out[]; };
#endif

void main() {
    uint k = gl_GlobalInvocationID.x;
    if (k >= sim.counts.x) return;
    uint i = texelFetch(order, int(k)).x;
    int c = int(texelFetch(keys, int(i)).x);
    uint s = texelFetch(start, c).x;
    uint place = s;
    for (uint m = s; m < s + texelFetch(counts, c).x; ++m) place += texelFetch(order, int(m)).x < i ? 1u : 0u;
    vec4 v = state_v(state_in, i);
    v.xyz += sim.lo_dt.w * sim.gravity_mass.xyz;
    state_out[place] = State(state_x(state_in, i), v);
    pred_out[place] = texelFetch(pred_in, int(i));
#ifdef REORDER_CARRY
    carry_out[place] = texelFetch(carry_in, int(i)).x;
#endif
}
