#version 460
//! sim_dfsph_begin — the first stage of a DFSPH step (Bender & Koschier 2015/2017, "Divergence-free SPH for
//! incompressible and viscous fluids"; src/sim/dfsph.rs): the neighbour grid is built on the positions the last
//! step ended at (DFSPH searches its neighbours once per step, at x; PBF at the predicted x*), so x is copied
//! where the `grid` pass and sim_reorder read the positions, with the κ the last step's constant-density solve
//! summed for the particle in w (the state and that sum share the last step's grid order): sim_reorder moves it
//! with the particle, and sim_dfsph_alpha takes half of it as the warm start (SPlisHSPlasH's USE_WARMSTART).
//! In: state (RGBA32UI texels, two per particle), kappa_sum. Out: pred (x, κ sum).
#include "sim_common.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(binding = 1) uniform usamplerBuffer state;   // read with state_x
layout(std430, binding = 2) writeonly buffer Pred { vec4 pred[]; };
layout(binding = 3) uniform samplerBuffer kappa_sum;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= sim.counts.x) return;
    pred[i] = vec4(state_x(state, i).xyz, texelFetch(kappa_sum, int(i)).x);
}
