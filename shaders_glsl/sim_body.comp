#version 460
//! sim_body — the dynamic rigid sphere's step (src/sim/scene.rs `Body`; DFSPH, after sim_dfsph_integrate): the
//! impulses the step's corrections gave it (body[BODY_HEAD + i], sim_dfsph_update's reactions to its push on the water)
//! summed, then semi-implicit Euler: v ← v + P / M + Δt g, c ← c + Δt v, then contact with the container's
//! faces: the centre kept R inside each face, the normal velocity reflected with the restitution (stopped below
//! 2 |g| Δt: resting contact), and Coulomb friction at the contact point with the sphere's rotation (I = 2/5 M R²:
//! a sliding sphere is slowed towards rolling, Δv_t = −2/7 of the contact point's speed at most, the friction
//! impulse at most μ times the normal one) — what SPlisHSPlasH's rigid-body contacts (restitutions multiplied,
//! frictions added; the scene file's reader combines them) give a sphere on a floor. One work group: the sum over
//! the particles is a tree in shared memory. In/out: body (sim_common.glsl's layout).
#define SIM_BODY_BINDING 1
#include "sim_common.glsl"
layout(local_size_x = 256) in;

shared vec3 s_sum[256];

void main() {
    uint l = gl_LocalInvocationID.x;
    vec3 sum = vec3(0.0);
    for (uint i = l; i < sim.counts.x; i += 256u) sum += body[BODY_HEAD + i].xyz;
    s_sum[l] = sum;
    barrier();
    for (uint s = 128u; s > 0u; s >>= 1u) {
        if (l < s) s_sum[l] += s_sum[l + s];
        barrier();
    }
    if (l != 0u || !body_on()) return;
    vec3 P = s_sum[0];
    float dt = sim.lo_dt.w;
    vec3 g = sim.gravity_mass.xyz;
    vec3 c = body[0].xyz, v = body[1].xyz, w = body[2].xyz;
    float R = body[0].w, M = body[1].w, e = body[3].x, mu = body[3].y;
    v += P / M + dt * g;
    c += dt * v;
    // The contact box's faces (the container's, or the scene file's collision box for bodies).
    vec3 lo = body[4].xyz, hi = body[5].xyz;
    for (int k = 0; k < 3; ++k) {
        for (int side = 0; side < 2; ++side) {
            float pen = side == 0 ? lo[k] + R - c[k] : c[k] - (hi[k] - R);
            if (pen <= 0.0) continue;
            c[k] = side == 0 ? lo[k] + R : hi[k] - R;
            vec3 n = vec3(0.0);
            n[k] = side == 0 ? 1.0 : -1.0;
            float vn = dot(v, n);
            if (vn >= 0.0) continue;
            float jn = vn > -2.0 * length(g) * dt ? -vn : -(1.0 + e) * vn;
            v += jn * n;
            vec3 vc = v + cross(w, -R * n);
            vec3 vt = vc - dot(vc, n) * n;
            float vtl = length(vt);
            if (vtl > 1e-9) {
                float jt = min(2.0 / 7.0 * vtl, mu * jn);
                vec3 t = vt / vtl;
                v -= jt * t;
                w += 5.0 * jt / (2.0 * R) * cross(n, t);
            }
        }
    }
    body[0].xyz = c;
    body[1].xyz = v;
    body[2].xyz = w;
    body[3].zw = vec2(length(P), 0.0);
}
