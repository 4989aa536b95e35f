#version 460
//! sim_diffuse_spawn — per fluid particle that may spawn: the limits (automatic: from the running maxima, a tenth
//! of each to each, the kinetic energy's lower limit at least `ke_floor`; else the hand-set ones), the clamped
//! potentials (eq. 1), round(foam_scale · I_ke · (I_ta + I_wc) · Δt) spawns (at most as many as its free slots)
//! in the cylinder around its velocity (eq. 10), written into its own free slots in order. Every random number
//! is diffuse::hash4(id, frame, spawn, channel), as on the CPU. src/diffuse/ `Generator::spawn`.
//! In: state; pot; run. Out: pool (this particle's slots).
#include "sim_diffuse.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(binding = 1) uniform usamplerBuffer state;
layout(std430, binding = 2) readonly buffer Pot { vec4 pot[]; };
layout(std430, binding = 3) readonly buffer Run { uint run[]; };
layout(std430, binding = 4) buffer Pool { vec4 pool[]; };

vec2 lim(float m) { return m > 0.0 ? vec2(0.1 * m, m) : vec2(0.0, MAX_FLOAT); }

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= sim.counts.x) return;
    vec4 p = pot[i];
    if (p.w == 0.0) return;
    vec2 l_ta = pc.manual_ta_wc.xy, l_wc = pc.manual_ta_wc.zw, l_ke = pc.manual_ke;
    if (pc.automatic != 0u) {
        l_ta = lim(uintBitsToFloat(run[0]));
        l_wc = lim(uintBitsToFloat(run[1]));
        float m = uintBitsToFloat(run[2]);
        l_ke = vec2(max(0.1 * m, pc.ke_floor), max(m, 2.0 * pc.ke_floor));
    }
    float i_ke = clamp_normalise(p.z, l_ke);
    float want = floor(pc.foam_scale * i_ke * (clamp_normalise(p.x, l_ta) + clamp_normalise(p.y, l_wc)) * pc.dt + 0.5);
    uint n = uint(max(want, 0.0));
    if (n == 0u) return;
    vec4 xs = state_x(state, i);
    uint id = floatBitsToUint(xs.w);
    uint base = id * pc.per_particle;
    if (base + pc.per_particle > pc.slots) return;
    vec3 x = xs.xyz;
    vec3 v = state_v(state, i).xyz;
    float speed = length(v);
    vec3 axis = speed > 0.0 ? v / speed : vec3(0.0, 1.0, 0.0);
    vec3 e1, e2;
    orthonormal_pair(axis, e1, e2);
    uint k = 0u;
    for (uint s = 0u; s < pc.per_particle && k < n; ++s) {
        uint at = base + s;
        if (pool[3u * at].w > 0.0) continue;
        float r = pc.radius * sqrt(unit(hash4(id, pc.frame, k, 0u)));
        float theta = 6.2831855 * unit(hash4(id, pc.frame, k, 1u));
        float hh = (unit(hash4(id, pc.frame, k, 2u)) - 0.5) * pc.dt * speed;
        vec3 radial = r * cos(theta) * e1 + r * sin(theta) * e2;
        float life = pc.life_min + i_ke * unit(hash4(id, pc.frame, k, 3u)) * (pc.life_max - pc.life_min);
        pool[3u * at] = vec4(x + radial + hh * axis, life);
        pool[3u * at + 1u] = vec4(radial + v, 0.0);
        pool[3u * at + 2u] = vec4(uintBitsToFloat(hash4(id, pc.frame, k, 7u)), float(DIFFUSE_FOAM), uintBitsToFloat(id), 0.0);
        k += 1u;
    }
}
