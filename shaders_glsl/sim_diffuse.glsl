//! sim_diffuse.glsl — the live simulation's diffuse particles on the GPU: src/diffuse/'s model (Ihmsen et al.
//! 2012, "Unified spray, foam and air bubbles for particle-based fluids"; Bender et al. 2019's automatic limits)
//! as stages after a frame's last step (src/sim/diffuse.rs): density and neighbour count, colour-field normals,
//! potentials (with the running maxima), advection of the pool, spawning into it, and the copy into the
//! renderer's particle buffer. Shared here: the push block (mirrored by `sim::diffuse::Push`), SPlisHSPlasH's
//! cubic spline (support h = 4 r), the spawn hash (`diffuse::hash4`), the orthonormal basis, the pool's layout.
//! The pool holds `per_particle` slots per fluid particle id, three vec4 per slot: (position, lifetime),
//! (velocity, age), (id bits, kind, source id bits, 0); a slot whose lifetime is ≤ 0 is free. A fluid particle
//! spawns into its own slots only, so no atomics place anything and the pool is the same on every run.
//! Neighbours are the particles within h found through the last step's grid (cells h wide; the grid was built
//! from the step's predicted positions, so a particle the solver moved across a cell border by more than the
//! neighbourhood's margin can be missed at the edge of the kernel, where it weighs almost nothing).
#include "sim_common.glsl"

layout(push_constant) uniform DiffusePush {
    float h;            // kernel support (4 r)
    float mass;         // 0.8 (2r)³ ρ0 (FoamGenerator's)
    float kk;           // cubic spline: 8 / (π h³)
    float kl;           // its derivative's 48 / (π h³)
    float radius;       // particle radius
    float dt;           // a frame
    float foam_scale;
    float ke_floor;     // least kinetic energy that spawns
    float life_min;
    float life_max;
    float buoyancy;
    float drag;
    float air_drag;
    uint spray_below;
    uint bubble_above;
    uint min_neighbours;
    uint per_particle;  // slots per fluid particle id
    uint frame;         // the frame number (the spawns' hash)
    uint automatic;     // 1: limits from the running maxima
    uint slots;         // slots in the pool
    vec4 manual_ta_wc;  // hand-set limits: trapped air (x, y), wave crest (z, w)
    vec2 manual_ke;     // kinetic energy
    float size;         // billboard radius (radii)
    float size_spread;
    float fade;         // seconds of fading out
    float fade_in;      // seconds of fading in
    uint out_offset;    // vec4 index of the diffuse header in the renderer's particle buffer (2 × fluid count)
    uint draw_cap;      // at most this many are appended for drawing
} pc;

const float MAX_FLOAT = 3.4028235e38;

float w_kernel(float r) {
    float q = r / pc.h;
    if (q <= 0.5) return pc.kk * (6.0 * q * q * q - 6.0 * q * q + 1.0);
    if (q <= 1.0) { float a = 1.0 - q; return pc.kk * 2.0 * (a * a * a); }
    return 0.0;
}

float dw_kernel(float r) {
    float q = r / pc.h;
    if (q <= 0.5) return pc.kl * q * (3.0 * q - 2.0) / pc.h;
    if (q <= 1.0) return -pc.kl * (1.0 - q) * (1.0 - q) / pc.h;
    return 0.0;
}

vec3 normalize_or_zero(vec3 v) {
    float l = length(v);
    return l > 0.0 ? v * (1.0 / l) : vec3(0.0);
}

uint rotl(uint x, uint k) { return (x << k) | (x >> (32u - k)); }

/// diffuse::hash4.
uint hash4(uint a, uint b, uint c, uint d) {
    uint h = 0x9e3779b9u;
    uint w[4] = uint[4](a, b, c, d);
    for (int k = 0; k < 4; ++k) {
        h ^= w[k] * 0x85ebca6bu;
        h = rotl(h, 13u) * 5u + 0xe6546b64u;
        h ^= h >> 16u;
        h *= 0x7feb352du;
        h ^= h >> 15u;
        h *= 0x846ca68bu;
        h ^= h >> 16u;
    }
    return h;
}

float unit(uint h) { return float(h >> 8u) / 16777216.0; }

/// diffuse::orthonormal_pair.
void orthonormal_pair(vec3 n, out vec3 e1, out vec3 e2) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float b = n.x * n.y * a;
    e1 = vec3(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
    e2 = vec3(b, s + n.y * n.y * a, -n.y);
}

/// diffuse::clamp_normalise (eq. 1).
float clamp_normalise(float v, vec2 lim) {
    if (lim.y <= lim.x) return 0.0;
    return (min(v, lim.y) - min(v, lim.x)) / (lim.y - lim.x);
}

/// A float's bits ordered as the floats are (for atomicMin over signed values).
uint sortable(float y) {
    uint b = floatBitsToUint(y);
    return y >= 0.0 ? (b | 0x80000000u) : ~b;
}

float unsortable(uint k) {
    return uintBitsToFloat((k & 0x80000000u) != 0u ? (k & 0x7fffffffu) : ~k);
}
