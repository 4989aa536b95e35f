#version 460
//! sim_solve — PBF position correction (Macklin & Müller 2013, eqs. 12–14), Jacobi: Δp_i = (m/ρ0)·Σ_j
//! (λ_i + λ_j + s_corr)·∇W_spiky(x*_i − x*_j), with the tensile-instability term s_corr = −k·(W(r)/W(Δq))ⁿ
//! (artificial pressure), plus the walls' λ_i·∇F (sim_common.glsl's wall_density); then collisions; x* ← x* + Δp, written to the other buffer (all Δp from one iterate).
//! In: the neighbour lists, pos_lambda (iterate k and λ, from sim_density). Out: pred (iterate k + 1).
#define SIM_SDF_BINDING 5
#include "sim_common.glsl"
layout(local_size_x = LOCAL_1D) in;
NEIGHBOUR_BUFFERS
layout(binding = 3) uniform samplerBuffer pos_lambda;
layout(std430, binding = 4) writeonly buffer PredOut { vec4 pred_out[]; };

// One neighbour's share of Δp_i / ((m/ρ0) × the spiky gradient's coefficient):
// (λ_i + λ_j + s_corr)·(h − |r|)² r/|r|. The constant factors are applied once after the loop, as in
// sim_density (docs/simulation.md, commit 961bada).
void visit(uint j, vec3 xi, float li, inout vec3 dp) {
    vec4 pj = texelFetch(pos_lambda, int(j));
    vec3 r = xi - pj.xyz;
    float r2 = dot(r, r);
    float s = -sim.solver.z * scorr_pow(poly6(r2) * sim.solver.w);
    float a2, il;
    spiky_terms(r2, a2, il);
    dp += ((li + pj.w + s) * a2 * il) * r;
}
#define VISIT(j) visit(j, xi, li, dp)

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= sim.counts.x) return;
    vec4 pi = texelFetch(pos_lambda, int(i));
    vec3 xi = pi.xyz;
    float li = pi.w;
    vec3 dp = vec3(0.0);
    FOR_NEIGHBOURS(i, VISIT)
    vec3 gw;
    wall_density(xi, gw);
    pred_out[i] = vec4(collide(xi + (sim.kern.w * sim.kern.z) * dp + li * gw), 0.0);
}
