#version 460
//! sim_dfsph_integrate — the end of a DFSPH step's solves: x ← x + Δt v with the corrected velocities, projected
//! out of the colliders and into the container (the solves keep the water out of the container's walls; the
//! other colliders are positions only). sim_velocity then takes v = (x_new − x)/Δt (so a projection stops the
//! velocity into a collider, with the container's static friction), and sim_viscosity applies XSPH and writes
//! the state and the renderer's particles — the same end as a PBF step.
//! In: pred (x, grid order), vel. Out: pred_out (the new positions). A dynamic body (binding 5) is a sphere
//! collider here too, where it stood at the step's start (sim_body moves it after), and takes the momentum the
//! projection stops (in: out: the particle's impulse on it).
#define SIM_SDF_BINDING 4
#define SIM_BODY_BINDING 5
#include "sim_common.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(binding = 1) uniform samplerBuffer pred;
layout(binding = 2) uniform samplerBuffer vel;
layout(std430, binding = 3) writeonly buffer PredOut { vec4 pred_out[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= sim.counts.x) return;
    vec3 x = collide(texelFetch(pred, int(i)).xyz + sim.lo_dt.w * texelFetch(vel, int(i)).xyz);
    if (body_on()) {
        vec3 d = x - body[0].xyz;
        float l = length(d), R = body[0].w + sim.visc.z;
        if (l < R) {
            vec3 pushed = body[0].xyz + (l > 1e-9 ? d / l : vec3(0.0, 1.0, 0.0)) * R;
            // The projection stops the particle's motion into the body: the body takes that momentum too.
            body[BODY_HEAD + i].xyz -= sim.gravity_mass.w * (pushed - x) / sim.lo_dt.w;
            x = pushed;
        }
    }
    pred_out[i] = vec4(x, 0.0);
}
