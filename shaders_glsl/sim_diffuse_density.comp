#version 460
//! sim_diffuse_density — per fluid particle (grid order, after the frame's last step): the diffuse model's SPH
//! density ρ_i = m (W(0) + Σ_j W(r_ij)) over the neighbours within h = 4 r and their number; and the lowest
//! particle's height (diffuse particles falling an h below it die). src/diffuse/ `Fluid::new`.
//! In: grid counts, start; state (grid order). Out: aux (ρ, neighbours, 0, 0), floor (sortable bits, atomicMin).
#include "sim_diffuse.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(binding = 1) uniform usamplerBuffer counts;
layout(binding = 2) uniform usamplerBuffer start;
layout(binding = 3) uniform usamplerBuffer state;
layout(std430, binding = 4) writeonly buffer Aux { vec4 aux[]; };
layout(std430, binding = 5) buffer Floor { uint floor_key[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= sim.counts.x) return;
    vec3 xi = state_x(state, i).xyz;
    float h2 = pc.h * pc.h;
    float rho = pc.mass * w_kernel(0.0);
    uint n = 0u;
    FOR_ROWS(xi, s, e)
        for (uint j = s; j < e; ++j) {
            if (j == i) continue;
            vec3 d = xi - state_x(state, j).xyz;
            float r2 = dot(d, d);
            if (r2 <= h2) {
                rho += pc.mass * w_kernel(sqrt(r2));
                n += 1u;
            }
        }
    END_ROWS
    aux[i] = vec4(rho, float(n), 0.0, 0.0);
    atomicMin(floor_key[0], sortable(xi.y));
}
