#version 460
//! sim_dfsph_rate — one evaluation of a DFSPH solve (Bender & Koschier 2017, Alg. 2 and 3; SPlisHSPlasH's
//! computeDensityChange / computeDensityAdv): the density-ratio change rate from the current velocities,
//!   d_i = Σ_j V (v_i − v_j)·∇W_ij + v_i·∇F_i   (the walls stand still),
//! then, by the specialization constant DFSPH_DENSITY:
//! - divergence solve (false): d_i clamped at 0 (only compression is corrected; 0 as well with fewer than 20
//!   neighbours, as SPlisHSPlasH does at a free surface), κ_i = d_i · factor_i / Δt, error d_i · Δt;
//! - constant-density solve (true): the predicted ratio ρ̂*_i = max(ρ̂_i + Δt d_i, 1), κ_i = (ρ̂*_i − 1) ·
//!   factor_i / Δt², error ρ̂*_i − 1.
//! Each work group sums its particles' errors into one partial (sim_dfsph_check reduces them).
//! In: the neighbour lists, pred (x), vel, dfsph (ρ̂, factor). Out: kappa, partials.
//! With a dynamic body (binding 8) its surface adds (v_i − v_body)·∇F_body, as the walls' term (they stand still).
#define SIM_BODY_BINDING 8
#include "sim_common.glsl"
layout(local_size_x = LOCAL_1D) in;
NEIGHBOUR_BUFFERS
layout(binding = 3) uniform samplerBuffer pred;
layout(binding = 4) uniform samplerBuffer vel;
layout(binding = 5) uniform samplerBuffer dfsph;
layout(std430, binding = 6) writeonly buffer Kappa { float kappa[]; };
layout(std430, binding = 7) writeonly buffer Partials { float partials[]; };

layout(constant_id = 3) const bool DFSPH_DENSITY = false;

shared float s_err[LOCAL_1D];

void visit(uint j, vec3 xi, vec3 vi, inout float d, inout uint nn) {
    vec3 r = xi - texelFetch(pred, int(j)).xyz;
    d += dot(vi - texelFetch(vel, int(j)).xyz, spiky_grad(r));
    nn += 1u;
}
#define VISIT(j) visit(j, xi, vi, d, nn)

void main() {
    uint i = gl_GlobalInvocationID.x;
    uint l = gl_LocalInvocationID.x;
    float err = 0.0;
    if (i < sim.counts.x) {
        vec3 xi = texelFetch(pred, int(i)).xyz;
        vec3 vi = texelFetch(vel, int(i)).xyz;
        float d = 0.0;
        uint nn = 0u;
        FOR_NEIGHBOURS(i, VISIT)
        vec3 gw, gb;
        wall_density(xi, gw);
        body_density(xi, gb);
        d = sim.kern.w * d + dot(vi, gw) + dot(vi - body_velocity(), gb);
        vec2 rf = texelFetch(dfsph, int(i)).xy;
        float dt = sim.lo_dt.w;
        float k;
        if (DFSPH_DENSITY) {
            float adv = max(rf.x + dt * d, 1.0);
            err = adv - 1.0;
            k = err * rf.y / (dt * dt);
        } else {
            d = nn < 20u ? 0.0 : max(d, 0.0);
            err = d * dt;
            k = d * rf.y / dt;
        }
        kappa[i] = k;
    }
    s_err[l] = err;
    barrier();
    for (uint s = LOCAL_1D / 2u; s > 0u; s >>= 1u) {
        if (l < s) s_err[l] += s_err[l + s];
        barrier();
    }
    if (l == 0u) partials[gl_WorkGroupID.x] = s_err[0];
}
