#version 460
//! sim_reorder — after the `grid` pass sorted the predicted positions into cells: gather the particles into
//! grid order, so every neighbour loop reads contiguous memory (Green 2008).
//! In: order (sorted place → particle), state, pred. Out: the same two arrays in grid order.
#include "sim_common.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, binding = 1) readonly buffer Order { uint order[]; };
layout(std430, binding = 2) readonly buffer StateIn { State state_in[]; };
layout(std430, binding = 3) readonly buffer PredIn { vec4 pred_in[]; };
layout(std430, binding = 4) writeonly buffer StateOut { State state_out[]; };
layout(std430, binding = 5) writeonly buffer PredOut { vec4 pred_out[]; };

void main() {
    uint k = gl_GlobalInvocationID.x;
    if (k >= sim.counts.x) return;
    uint i = order[k];
    state_out[k] = state_in[i];
    pred_out[k] = pred_in[i];
}
