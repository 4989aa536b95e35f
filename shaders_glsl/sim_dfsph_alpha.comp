#version 460
//! sim_dfsph_alpha — DFSPH's per-particle density and factor (Bender & Koschier 2017, eqs. 9–11; SPlisHSPlasH's
//! computeDFSPHFactor, in its density-ratio form): ρ̂_i = Σ_j V W_poly6(x_i − x_j) + F_i (the container walls'
//! share, sim_common.glsl's wall_density), and
//!   factor_i = −1 / (|Σ_j V ∇W_ij + ∇F_i|² + Σ_j |V ∇W_ij|²)   (0 where that sum vanishes),
//! with the spiky gradient, V = m/ρ0 the particle volume. The velocity the solves start from is the sorted
//! state's (sim_reorder added Δt·g to it), copied to `vel`, which the solves update in place. The warm start of
//! the constant-density solve: half the κ the particle's last solve summed (pred.w, carried by sim_dfsph_begin),
//! applied as one correction before the solve (Bender & Koschier 2017 §4.4; SPlisHSPlasH's USE_WARMSTART);
//! this step's sum starts at 0. The divergence-free solve's likewise (USE_WARMSTART_V): its last sum arrives in
//! kappa_v_warm (sim_reorder's carry), halved here in place.
//! In: the neighbour lists, pred (x, grid order; w: the last κ sum), the sorted state. Out: dfsph (ρ̂, factor),
//! vel, density (kg/m³, exported with the cache), kappa_warm, kappa_sum, kappa_v_sum. In/out: kappa_v_warm.
//! With a dynamic body (binding 12, sim_common.glsl's body_density) its surface adds to ρ̂ and the factor as the
//! walls do, and the particle's impulse on it starts at 0.
#define SIM_BODY_BINDING 12
#include "sim_common.glsl"
layout(local_size_x = LOCAL_1D) in;
NEIGHBOUR_BUFFERS
layout(binding = 3) uniform samplerBuffer pred;
layout(binding = 4) uniform usamplerBuffer sorted;   // read with state_v
layout(std430, binding = 5) writeonly buffer Dfsph { vec4 dfsph[]; };
layout(std430, binding = 6) writeonly buffer Vel { vec4 vel[]; };
layout(std430, binding = 7) writeonly buffer Density { float density[]; };
layout(std430, binding = 8) writeonly buffer KappaWarm { float kappa_warm[]; };
layout(std430, binding = 9) writeonly buffer KappaSum { float kappa_sum[]; };
layout(std430, binding = 10) buffer KappaVWarm { float kappa_v_warm[]; };
layout(std430, binding = 11) writeonly buffer KappaVSum { float kappa_v_sum[]; };

void visit(uint j, vec3 xi, inout float wsum, inout vec3 gsum, inout float g2) {
    vec3 r = xi - texelFetch(pred, int(j)).xyz;
    wsum += poly6(dot(r, r));
    vec3 g = sim.kern.w * spiky_grad(r);
    gsum += g;
    g2 += dot(g, g);
}
#define VISIT(j) visit(j, xi, wsum, gsum, g2)

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= sim.counts.x) return;
    vec4 pi = texelFetch(pred, int(i));
    vec3 xi = pi.xyz;
    float wsum = poly6(0.0);
    vec3 gsum = vec3(0.0);
    float g2 = 0.0;
    FOR_NEIGHBOURS(i, VISIT)
    vec3 gw, gb;
    float rho = sim.kern.w * wsum + wall_density(xi, gw) + body_density(xi, gb);
    vec3 s1 = gsum + gw + gb;
    if (body_on()) body[BODY_HEAD + i] = vec4(0.0);
    float s = dot(s1, s1) + g2;
    dfsph[i] = vec4(rho, s > 1e-6 ? -1.0 / s : 0.0, 0.0, 0.0);
    vel[i] = vec4(state_v(sorted, i).xyz, 0.0);
    density[i] = rho * sim.solver.x;
    kappa_warm[i] = 0.5 * pi.w;
    kappa_sum[i] = 0.0;
    kappa_v_warm[i] *= 0.5;
    kappa_v_sum[i] = 0.0;
}
