#version 460
//! sim_predict — PBF step 1 (Macklin & Müller 2013, Alg. 1 lines 1–4): v ← v + Δt·g; x* ← x + Δt·v, projected
//! out of the colliders and into the container.
//! In/out: state (v updated). Out: pred (x*).
#define SIM_SDF_BINDING 3
#include "sim_common.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, binding = 1) buffer States { State state[]; };
layout(std430, binding = 2) writeonly buffer Pred { vec4 pred[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= sim.counts.x) return;
    float dt = sim.lo_dt.w;
    vec3 v = state[i].v.xyz + dt * sim.gravity_mass.xyz;
    state[i].v.xyz = v;
    pred[i] = vec4(collide(state[i].x.xyz + dt * v), 0.0);
}
