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

// One neighbour's share of ρ_i (poly6), ∇_i C_i and Σ_k |∇_k C_i|².
void visit(uint j, vec3 xi, float vol, inout float w, inout vec3 grad_i, inout float sum2) {
    vec3 r = xi - texelFetch(pred, int(j)).xyz;
    w += poly6(dot(r, r));
    vec3 g = vol * spiky_grad(r);
    grad_i += g;
    sum2 += dot(g, g);
}
#define VISIT(j) visit(j, xi, vol, w, grad_i, sum2)

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= sim.counts.x) return;
    vec3 xi = texelFetch(pred, int(i)).xyz;
    float vol = sim.kern.w;
    float w = poly6(0.0);
    vec3 grad_i = vec3(0.0);
    float sum2 = 0.0;
    FOR_NEIGHBOURS(i, VISIT)
    vec3 gw;
    float fw = wall_density(xi, gw);
    grad_i += gw;
    float rho = sim.gravity_mass.w * w + sim.solver.x * fw;
    float C = max(rho / sim.solver.x - 1.0, 0.0);
    pos_lambda[i] = vec4(xi, -C / (sum2 + dot(grad_i, grad_i) + sim.solver.y));
    density[i] = rho;
}
