#version 460
//! sim_dfsph_integrate — the end of a DFSPH step's solves: x ← x + Δt v with the corrected velocities, projected
//! out of the colliders and into the container (the solves keep the water out of the container's walls; the
//! other colliders are positions only). sim_velocity then takes v = (x_new − x)/Δt (so a projection stops the
//! velocity into a collider, with the container's static friction), and sim_viscosity applies XSPH and writes
//! the state and the renderer's particles — the same end as a PBF step.
//! In: pred (x, grid order), vel. Out: pred_out (the new positions).
#define SIM_SDF_BINDING 4
#include "sim_common.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(binding = 1) uniform samplerBuffer pred;
layout(binding = 2) uniform samplerBuffer vel;
layout(std430, binding = 3) writeonly buffer PredOut { vec4 pred_out[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= sim.counts.x) return;
    pred_out[i] = vec4(collide(texelFetch(pred, int(i)).xyz + sim.lo_dt.w * texelFetch(vel, int(i)).xyz), 0.0);
}
