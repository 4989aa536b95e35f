#version 460
//! sim_predict — PBF step 1 (Macklin & Müller 2013, Alg. 1 lines 1–4): v ← v + Δt·g; x* ← x + Δt·v, projected
//! out of the colliders and into the container. Only x* is written here; sim_reorder stores the same v + Δt·g
//! with the state it moves into grid order (one write of the state per step instead of two: on lavapipe each
//! component of a storage-buffer access is a loop over the lanes, and this stage had been mostly that).
//! In: state (RGBA32UI texels, two per particle). Out: pred (x*).
#define SIM_SDF_BINDING 3
#include "sim_common.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(binding = 1) uniform usamplerBuffer state;   // x, v of particle i at texels 2i, 2i + 1
layout(std430, binding = 2) writeonly buffer Pred { vec4 pred[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= sim.counts.x) return;
    float dt = sim.lo_dt.w;
    vec3 v = uintBitsToFloat(texelFetch(state, int(2u * i + 1u)).xyz) + dt * sim.gravity_mass.xyz;
    pred[i] = vec4(collide(uintBitsToFloat(texelFetch(state, int(2u * i)).xyz) + dt * v), 0.0);
}
