#version 460
//! sim_velocity — PBF velocity update (Macklin & Müller 2013, Alg. 1 line 21): v = (x* − x) / Δt.
//! In: state (x), pred (final x*). Out: vel (the new velocities, grid order).
#include "sim_common.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, binding = 1) readonly buffer States { State state[]; };
layout(std430, binding = 2) readonly buffer Pred { vec4 pred[]; };
layout(std430, binding = 3) writeonly buffer Vel { vec4 vel[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= sim.counts.x) return;
    vel[i] = vec4((pred[i].xyz - state[i].x.xyz) / sim.lo_dt.w, 0.0);
}
