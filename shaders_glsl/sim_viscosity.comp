#version 460
//! sim_viscosity — the end of a PBF step (Macklin & Müller 2013, eqs. 16–17): vorticity confinement
//! f = ε_v·(N × ω_i), N = η/|η|, η = Σ_j V·(|ω_j| − |ω_i|)·∇W_spiky(x_i − x_j); then XSPH viscosity
//! v_i ← v_i + c·Σ_j V·(v_j − v_i)·W_poly6(x_i − x_j); x ← x* (in the emitter's nozzle: v ← the nozzle's
//! velocity, x ← x + Δt v). Writes the new state (grid order of this step)
//! and the renderer's particles (xyz, w = 0: the frame radius), then after them the motions (id bits, |Δv|/Δt).
//! The frame's largest speed is kept (max over its steps) for the adaptive step's CFL bound (`[sim]
//! adaptive_step`; SPlisHSPlasH's cflMethod 1): each work group's largest |v|, then one atomic max of its bits
//! (non-negative floats order as their bits).
//! In: the neighbour lists, pred, vel, omega, the sorted state (ids). Out: state, particles. In/out: speed.
#include "sim_common.glsl"
layout(local_size_x = LOCAL_1D) in;
NEIGHBOUR_BUFFERS
layout(binding = 3) uniform samplerBuffer pred;
layout(binding = 4) uniform samplerBuffer vel;
layout(binding = 5) uniform samplerBuffer omega;
layout(binding = 6) uniform usamplerBuffer sorted;   // the sorted state (state_x: its id bits)
layout(std430, binding = 7) writeonly buffer States { State state[]; };
layout(std430, binding = 8) writeonly buffer Particles { vec4 particles[]; };
layout(std430, binding = 9) buffer Speed { uint speed_max; };  // float bits, cleared to 0 at the frame's start

// Whether vorticity confinement is on (ε > 0), a specialization constant (Stages::new): lavapipe runs both sides of
// a branch, so with a uniform's test every particle walked its list twice, once with confinement's fetches and
// gradient (docs/simulation.md, commit 961bada).
layout(constant_id = 2) const bool SIM_CONFINE = true;

// One neighbour's share of XSPH's Σ (v_j − v_i) W_poly6, and with confinement of η.
void visit(uint j, vec3 xi, vec3 vi, float wi, inout vec3 xsph, inout vec3 eta) {
    vec3 r = xi - texelFetch(pred, int(j)).xyz;
    if (SIM_CONFINE) eta += (texelFetch(omega, int(j)).w - wi) * spiky_grad(r);
    xsph += (texelFetch(vel, int(j)).xyz - vi) * poly6(dot(r, r));
}
#define VISIT(j) visit(j, xi, vi, wi, xsph, eta)

shared float s_speed[LOCAL_1D];

/// Particle i's end of step; returns its new speed.
float end_step(uint i) {
    vec3 xi = texelFetch(pred, int(i)).xyz;
    vec3 vi = texelFetch(vel, int(i)).xyz;
    float vol = sim.kern.w;
    vec3 xsph = vec3(0.0);
    vec4 omega_i = SIM_CONFINE ? texelFetch(omega, int(i)) : vec4(0.0);  // ω_i (xyz), |ω_i| (w)
    float wi = omega_i.w;
    vec3 eta = vec3(0.0);
    FOR_NEIGHBOURS(i, VISIT)
    vec3 v = vi + sim.visc.x * vol * xsph;
    if (SIM_CONFINE) {
        eta *= vol;
        float le = length(eta);
        if (le > 1e-9) v += sim.lo_dt.w * sim.visc.y * cross(eta / le, omega_i.xyz);
    }
    vec4 xs = state_x(sorted, i);
    // A particle in the emitter's nozzle moves at its velocity from where the step started, as SPlisHSPlasH's
    // emitters animate theirs (no gravity, pressure or viscosity there).
    if (in_nozzle(xs.xyz)) {
        v = sim.nozzle[4].xyz;
        xi = xs.xyz + sim.lo_dt.w * v;
    }
    // How fast the velocity changes, |Δv| / Δt, for the renderer's noise (NVIDIA patent US 8,947,430, eq. 17):
    // this step's (the sorted state's velocity has gravity's Δt·g added: take it back out), low-passed over
    // about one frame (sim.visc.w = Δt / (Δt + frame time)) so that it measures what a sequence's frames would,
    // not one step's solver noise. It lives in the velocity's w and travels with the particle through the sorts.
    vec4 vs = state_v(sorted, i);
    float accel = mix(vs.w, length(v - (vs.xyz - sim.lo_dt.w * sim.gravity_mass.xyz)) / sim.lo_dt.w, sim.visc.w);
    state[i] = State(vec4(xi, xs.w), vec4(v, accel));
    particles[i] = vec4(xi, 0.0);
    // The renderer's motion entry (particle_layout.glsl): the id bits and the change of velocity.
    particles[particle_motion(sim.counts.x, i)] = vec4(xs.w, accel, 0.0, 0.0);
    return length(v);
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    uint l = gl_LocalInvocationID.x;
    s_speed[l] = i < sim.counts.x ? end_step(i) : 0.0;
    barrier();
    for (uint s = LOCAL_1D / 2u; s > 0u; s >>= 1u) {
        if (l < s) s_speed[l] = max(s_speed[l], s_speed[l + s]);
        barrier();
    }
    if (l == 0u) atomicMax(speed_max, floatBitsToUint(s_speed[0]));
}
