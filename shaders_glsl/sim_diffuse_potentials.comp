#version 460
//! sim_diffuse_potentials — per fluid particle with at least `min_neighbours` neighbours: Ihmsen eq. 2 (trapped
//! air: Σ V_j |v_ij| (1 − v̂_ij·x̂_ij) W_ij), eq. 4–7 (wave crest: Σ V_j (1 − n̂_i·n̂_j) W_ij over the neighbours
//! behind the surface, where it moves along its normal) and the kinetic energy ½ m |v|², unclamped; their
//! running maxima over the run (atomicMax on the bits of non-negative floats: order-independent), from which the
//! spawn stage takes the automatic limits. src/diffuse/ `Fluid::potentials`, `Live`.
//! In: grid counts, start; state; aux; normals. Out: pot (ta, wc, ke, 1 when it may spawn), run (maxima bits).
#include "sim_diffuse.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(binding = 1) uniform usamplerBuffer counts;
layout(binding = 2) uniform usamplerBuffer start;
layout(binding = 3) uniform usamplerBuffer state;
layout(std430, binding = 4) readonly buffer Aux { vec4 aux[]; };
layout(std430, binding = 5) readonly buffer Normals { vec4 normals[]; };
layout(std430, binding = 6) writeonly buffer Pot { vec4 pot[]; };
layout(std430, binding = 7) buffer Run { uint run[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= sim.counts.x) return;
    if (uint(aux[i].y) < pc.min_neighbours) {
        pot[i] = vec4(0.0);
        return;
    }
    vec3 xi = state_x(state, i).xyz;
    vec3 vi = state_v(state, i).xyz;
    vec3 ni = normals[i].xyz;
    float h2 = pc.h * pc.h;
    float ta = 0.0;
    float wc = 0.0;
    FOR_ROWS(xi, s, e)
        for (uint j = s; j < e; ++j) {
            if (j == i) continue;
            vec3 xj = state_x(state, j).xyz;
            vec3 d = xi - xj;
            if (dot(d, d) > h2) continue;
            float r = length(d);
            float w = pc.mass / aux[j].x * w_kernel(r);
            vec3 xij = normalize_or_zero(d);
            vec3 vij = vi - state_v(state, j).xyz;
            float speed = length(vij);
            vec3 vdir = speed > 1e-6 ? vij / speed : vij;
            ta += speed * (1.0 - dot(vdir, xij)) * w;
            if (dot(normalize_or_zero(xj - xi), ni) < 0.0) wc += (1.0 - dot(ni, normals[j].xyz)) * w;
        }
    END_ROWS
    if (dot(normalize_or_zero(vi), ni) < 0.6) wc = 0.0;
    float ke = 0.5 * pc.mass * dot(vi, vi);
    pot[i] = vec4(ta, wc, ke, 1.0);
    atomicMax(run[0], floatBitsToUint(ta));
    atomicMax(run[1], floatBitsToUint(wc));
    atomicMax(run[2], floatBitsToUint(ke));
}
