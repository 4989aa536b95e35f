#version 460
//! sim_diffuse_normals — per fluid particle near the surface (at most 20 neighbours): the colour field's normal
//! n_i = normalize(Σ_j m/ρ_j (−dW/dr) (x_i − x_j)/r), pointing out of the water (src/diffuse/ `Fluid::new`);
//! zero inside.
//! In: grid counts, start; state; aux (ρ, neighbours). Out: normals (xyz).
#include "sim_diffuse.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(binding = 1) uniform usamplerBuffer counts;
layout(binding = 2) uniform usamplerBuffer start;
layout(binding = 3) uniform usamplerBuffer state;
layout(std430, binding = 4) readonly buffer Aux { vec4 aux[]; };
layout(std430, binding = 5) writeonly buffer Normals { vec4 normals[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= sim.counts.x) return;
    if (aux[i].y > 20.0) {
        normals[i] = vec4(0.0);
        return;
    }
    vec3 xi = state_x(state, i).xyz;
    float h2 = pc.h * pc.h;
    vec3 g = vec3(0.0);
    FOR_ROWS(xi, s, e)
        for (uint j = s; j < e; ++j) {
            if (j == i) continue;
            vec3 d = xi - state_x(state, j).xyz;
            float r2 = dot(d, d);
            float r = sqrt(r2);
            if (r2 <= h2 && r > 1e-9) g += pc.mass / aux[j].x * -dw_kernel(r) * d / r;
        }
    END_ROWS
    normals[i] = vec4(normalize_or_zero(g), 0.0);
}
