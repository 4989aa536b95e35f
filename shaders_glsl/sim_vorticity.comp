#version 460
//! sim_vorticity — vorticity at every particle (Macklin & Müller 2013, eq. 15; Fedkiw et al. 2001):
//! ω_i = Σ_j V·(v_j − v_i) × ∇_j W_spiky(x_i − x_j), V = m/ρ0 and ∇_j W(x_i − x_j) = −∇W_spiky(x_i − x_j).
//! In: the neighbour lists, pred, vel. Out: omega (xyz; w = |ω|).
#include "sim_common.glsl"
layout(local_size_x = LOCAL_1D) in;
NEIGHBOUR_BUFFERS
layout(binding = 3) uniform samplerBuffer pred;
layout(binding = 4) uniform samplerBuffer vel;
layout(std430, binding = 5) writeonly buffer Omega { vec4 omega[]; };

// One neighbour's share of ω_i.
void visit(uint j, vec3 xi, vec3 vi, inout vec3 w) {
    w += cross(texelFetch(vel, int(j)).xyz - vi, -spiky_grad(xi - texelFetch(pred, int(j)).xyz));
}
#define VISIT(j) visit(j, xi, vi, w)

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= sim.counts.x) return;
    vec3 xi = texelFetch(pred, int(i)).xyz;
    vec3 vi = texelFetch(vel, int(i)).xyz;
    vec3 w = vec3(0.0);
    FOR_NEIGHBOURS(i, VISIT)
    w *= sim.kern.w;
    omega[i] = vec4(w, length(w));
}
