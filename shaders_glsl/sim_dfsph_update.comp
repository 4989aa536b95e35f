#version 460
//! sim_dfsph_update — one velocity correction of a DFSPH solve (Bender & Koschier 2017, eqs. 12–13, Jacobi;
//! SPlisHSPlasH's pressureSolveIteration / divergenceSolveIteration): from every particle's κ (sim_dfsph_rate),
//!   v_i ← v_i + Δt Σ_j V (κ_i + κ_j) ∇W_ij + Δt κ_i ∇F_i
//! (κ ≤ 0 where compressed, so the push is away from the neighbours and out of the walls). Only particle i's own
//! velocity is read and written, so the update is in place. The κ applied is summed per particle (the next
//! step's warm start of the same solve).
//! In: the neighbour lists, pred (x), kappa. In/out: vel, kappa_sum.
//! With a dynamic body (binding 7) its surface pushes as the walls do, Δt κ_i ∇F_body, and the body takes the
//! reaction: the particle's impulse on it, −m Δt κ_i ∇F_body, summed over the step's corrections in body[BODY_HEAD + i]
//! (SPlisHSPlasH's DFSPH adds −m_i Δv to a dynamic boundary the same way).
#define SIM_BODY_BINDING 7
#include "sim_common.glsl"
layout(local_size_x = LOCAL_1D) in;
NEIGHBOUR_BUFFERS
layout(binding = 3) uniform samplerBuffer pred;
layout(binding = 4) uniform samplerBuffer kappa;
layout(std430, binding = 5) buffer Vel { vec4 vel[]; };
layout(std430, binding = 6) buffer KappaSum { float kappa_sum[]; };

void visit(uint j, vec3 xi, float ki, inout vec3 dv) {
    vec3 r = xi - texelFetch(pred, int(j)).xyz;
    dv += (ki + texelFetch(kappa, int(j)).x) * spiky_grad(r);
}
#define VISIT(j) visit(j, xi, ki, dv)

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= sim.counts.x) return;
    vec3 xi = texelFetch(pred, int(i)).xyz;
    float ki = texelFetch(kappa, int(i)).x;
    vec3 dv = vec3(0.0);
    FOR_NEIGHBOURS(i, VISIT)
    vec3 gw, gb;
    wall_density(xi, gw);
    body_density(xi, gb);
    float dt = sim.lo_dt.w;
    vel[i].xyz += dt * (sim.kern.w * dv + ki * (gw + gb));
    if (body_on()) body[BODY_HEAD + i].xyz -= sim.gravity_mass.w * dt * ki * gb;
    kappa_sum[i] += ki;
}
