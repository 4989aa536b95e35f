#version 460
//! sim_diffuse_advect — per pool slot holding a living diffuse particle: classify it by its fluid neighbours
//! within h (fewer than spray_below: spray; more than bubble_above: bubble; else foam) and move it (Ihmsen eq.
//! 11–13): spray ballistically with air drag, foam with the SPH-interpolated fluid velocity Σ W v / Σ W, bubbles
//! by buoyancy and drag toward it; it ages, and dies at the end of its lifetime or an h below the water's lowest
//! particle. src/diffuse/ `Generator::advect`.
//! In: grid counts, start; state; floor. Out: pool (in place).
#include "sim_diffuse.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(binding = 1) uniform usamplerBuffer counts;
layout(binding = 2) uniform usamplerBuffer start;
layout(binding = 3) uniform usamplerBuffer state;
layout(std430, binding = 4) readonly buffer Floor { uint floor_key[]; };
layout(std430, binding = 5) buffer Pool { vec4 pool[]; };

void main() {
    uint k = gl_GlobalInvocationID.x;
    if (k >= pc.slots) return;
    vec4 a = pool[3u * k];
    if (!(a.w > 0.0)) return;
    vec4 b = pool[3u * k + 1u];
    vec4 c = pool[3u * k + 2u];
    vec3 x = a.xyz;
    vec3 v = b.xyz;
    float life = a.w;
    float h2 = pc.h * pc.h;
    vec3 vf = vec3(0.0);
    float sum = 0.0;
    uint n = 0u;
    FOR_ROWS(x, s, e)
        for (uint j = s; j < e; ++j) {
            vec3 d = state_x(state, j).xyz - x;
            float r2 = dot(d, d);
            if (r2 <= h2) {
                float w = w_kernel(sqrt(r2));
                vf += w * state_v(state, j).xyz;
                sum += w;
                n += 1u;
            }
        }
    END_ROWS
    vf = sum > 0.0 ? vf / sum : vec3(0.0);
    uint kind = n < pc.spray_below ? DIFFUSE_SPRAY : (n > pc.bubble_above ? DIFFUSE_BUBBLE : DIFFUSE_FOAM);
    vec3 g = sim.gravity_mass.xyz;
    if (kind == DIFFUSE_SPRAY) {
        v += pc.dt * (g - pc.air_drag * v);
        x += pc.dt * v;
    } else if (kind == DIFFUSE_FOAM) {
        v = vf;
        x += pc.dt * vf;
    } else {
        v += -pc.buoyancy * pc.dt * g + pc.drag * (vf - v);
        x += pc.dt * v;
    }
    life -= pc.dt;
    float floor_y = unsortable(floor_key[0]) - pc.h;
    if (!(x.y >= floor_y) || any(isinf(x)) || any(isnan(x))) life = 0.0;
    pool[3u * k] = vec4(x, life);
    pool[3u * k + 1u] = vec4(v, b.w + pc.dt);
    pool[3u * k + 2u] = vec4(c.x, float(kind), c.z, 0.0);
}
