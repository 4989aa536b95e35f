#version 460
//! sim_predict — PBF step 1 (Macklin & Müller 2013, Alg. 1 lines 1–4): v ← v + Δt·g; x* ← x + Δt·v, projected
//! out of the colliders and into the container. Only x* is written here; sim_reorder stores the same v + Δt·g
//! with the state it moves into grid order (one write of the state per step instead of two: on lavapipe each
//! component of a storage-buffer access is a loop over the lanes, and this stage had been mostly that).
//! In: state (RGBA32UI texels, two per particle). Out: pred (x*).
#define SIM_SDF_BINDING 3
#include "sim_common.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(binding = 1) uniform usamplerBuffer state;   // read with state_x, state_v
layout(std430, binding = 2) writeonly buffer Pred { vec4 pred[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= sim.counts.x) return;
    float dt = sim.lo_dt.w;
    vec3 v = state_v(state, i).xyz + dt * sim.gravity_mass.xyz;
    pred[i] = vec4(collide(state_x(state, i).xyz + dt * v), 0.0);
}
