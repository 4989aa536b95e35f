#version 460
//! sim_velocity — PBF velocity update (Macklin & Müller 2013, Alg. 1 line 21): v = (x* − x) / Δt, then static
//! friction against the container's faces (Coulomb, as in Macklin et al. 2014, "Unified particle physics",
//! §6.1, at the velocity level and static only): a particle the solver left on a face keeps no tangential
//! velocity when that velocity is at most μ_s times the normal velocity change the step's constraints made
//! (the face's push: g·Δt for water resting on the floor). Flowing water (a dam-break surge is 100× faster than
//! that bound) slides freely, as on SPlisHSPlasH's free-slip walls; water at rest does not creep along the
//! floor. A particle the emitter's nozzle holds (in_nozzle at its step's start) takes the nozzle's velocity.
//! In: the sorted state (x, and v after gravity as sim_reorder stored it; RGBA32UI texels, two per
//! particle), pred (final x*, texels). Out: vel (grid order).
#include "sim_common.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(binding = 1) uniform usamplerBuffer state;   // read with state_x, state_v
layout(binding = 2) uniform samplerBuffer pred;
layout(std430, binding = 3) writeonly buffer Vel { vec4 vel[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= sim.counts.x) return;
    vec3 xs = texelFetch(pred, int(i)).xyz;
    vec3 v = (xs - state_x(state, i).xyz) / sim.lo_dt.w;
    vec3 vp = state_v(state, i).xyz;
    float mu = sim.wall.x;
    for (int k = 0; k < 3; ++k) {
        // +1 on a lower face, −1 on an upper one (the clamp in collide() leaves x* exactly on the bound).
        float side = xs[k] <= sim.lo_dt[k] ? 1.0 : (xs[k] >= sim.hi_h[k] ? -1.0 : 0.0);
        vec3 vt = v;
        vt[k] = 0.0;
        float push = side * (v[k] - vp[k]);
        if (side != 0.0 && push > 0.0 && dot(vt, vt) <= mu * mu * push * push) v = v - vt;
    }
    // The emitter's nozzle moves its particles at its own velocity (sim_common.glsl in_nozzle).
    if (in_nozzle(state_x(state, i).xyz)) v = sim.nozzle[4].xyz;
    vel[i] = vec4(v, 0.0);
}
