#version 460
//! sim_density — PBF density constraint (Macklin & Müller 2013, eqs. 1–11): ρ_i = Σ_j m W_poly6(x*_i − x*_j),
//! C_i = max(ρ_i/ρ0 − 1, 0) (unilateral: a particle at the free surface is not pulled outward, the usual
//! choice since FleX), λ_i = −C_i / (Σ_k |∇_k C_i|² + ε), ∇_k C_i = (m/ρ0)·∇W_spiky.
//! The container walls add their density and gradient (sim_common.glsl's wall_density).
//! In: the neighbour lists, pred. Out: pos_lambda (x*_i, λ_i: sim_solve reads both with one load per
//! neighbour), density (kg/m³, exported with the cache).
#include "sim_common.glsl"
layout(local_size_x = LOCAL_1D) in;
NEIGHBOUR_BUFFERS
layout(binding = 3) uniform samplerBuffer pred;
layout(std430, binding = 4) writeonly buffer PosLambda { vec4 pos_lambda[]; };
layout(std430, binding = 5) writeonly buffer Density { float density[]; };

// One neighbour's share of ρ_i and ∇_i C_i, with the kernels' constant factors taken out of the loop: wsum
// gathers (h² − r²)³ (poly6 / its coefficient), gsum (h − |r|)² r/|r| (the spiky gradient / its coefficient), a4
// (h − |r|)⁴ = |that|², so Σ_k |∇_k C_i|² needs no dot product per neighbour. Why: on lavapipe the kernels'
// arithmetic, not the loads, was two thirds of this stage (docs/simulation.md, commit 961bada).
void visit(uint j, vec3 xi, inout float wsum, inout vec3 gsum, inout float a4) {
    vec3 r = xi - texelFetch(pred, int(j)).xyz;
    float r2 = dot(r, r);
    wsum += poly6_terms(r2);
    float a2, il;
    spiky_terms(r2, a2, il);
    gsum += (a2 * il) * r;
    a4 += a2 * a2;
}
#define VISIT(j) visit(j, xi, wsum, gsum, a4)

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= sim.counts.x) return;
    vec3 xi = texelFetch(pred, int(i)).xyz;
    float wsum = poly6_terms(0.0);
    vec3 gsum = vec3(0.0);
    float a4 = 0.0;
    FOR_NEIGHBOURS(i, VISIT)
    float cg = sim.kern.w * sim.kern.z;  // (m/ρ0) × the spiky gradient's coefficient
    vec3 gw;
    float fw = wall_density(xi, gw);
    vec3 grad_i = cg * gsum + gw;
    float sum2 = cg * cg * a4;
    float rho = sim.gravity_mass.w * (sim.kern.y * wsum) + sim.solver.x * fw;
    float C = max(rho / sim.solver.x - 1.0, 0.0);
    pos_lambda[i] = vec4(xi, -C / (sum2 + dot(grad_i, grad_i) + sim.solver.y));
    density[i] = rho;
}
