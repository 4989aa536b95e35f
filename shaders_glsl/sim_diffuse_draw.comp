#version 460
//! sim_diffuse_draw — per pool slot holding a living diffuse particle: the `diffuse` pass's two vec4 (position and
//! billboard radius; velocity and kind + fade; passes::diffuse::encode, on the GPU) appended to the renderer's
//! particle buffer after the fluid's positions and motions and a header vec4 (uint: groups of LOCAL_1D to
//! dispatch, 1, 1, particles appended), which the pass dispatches indirectly from. The order of the appends
//! comes from the atomics; the drawn image does not depend on it (the pass sums fixed-point coverage). At most
//! `draw_cap` are appended; the count goes on past it, and the pass clamps.
//! In: pool. Out: the particle buffer's header (zeroed before this stage) and diffuse region.
#include "sim_diffuse.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, binding = 1) readonly buffer Pool { vec4 pool[]; };
layout(std430, binding = 2) buffer Out { uint words[]; };

float ramp(float t, float over) { return over > 0.0 ? t / over : 1.0; }

void put(uint at, vec4 v) {
    words[4u * at] = floatBitsToUint(v.x);
    words[4u * at + 1u] = floatBitsToUint(v.y);
    words[4u * at + 2u] = floatBitsToUint(v.z);
    words[4u * at + 3u] = floatBitsToUint(v.w);
}

void main() {
    uint k = gl_GlobalInvocationID.x;
    if (k >= pc.slots) return;
    vec4 a = pool[3u * k];
    if (!(a.w > 0.0)) return;
    uint hdr = pc.out_offset;
    uint at = atomicAdd(words[4u * hdr + 3u], 1u);
    if (at >= pc.draw_cap) return;
    if (at % LOCAL_1D == 0u) atomicAdd(words[4u * hdr], 1u);
    if (at == 0u) {
        words[4u * hdr + 1u] = 1u;
        words[4u * hdr + 2u] = 1u;
    }
    vec4 b = pool[3u * k + 1u];
    vec4 c = pool[3u * k + 2u];
    float u = unit(hash4(floatBitsToUint(c.x), 0x5eedu, 0u, 0u));
    float size = pc.size * pc.radius * (1.0 + pc.size_spread * (2.0 * u - 1.0));
    float fade = clamp(min(ramp(a.w, pc.fade), ramp(b.w, pc.fade_in)), 1e-3, 0.999);
    // After the header (particle_layout.glsl: the diffuse particles follow it, DIFFUSE_VEC4S each).
    put(hdr + 1u + DIFFUSE_VEC4S * at, vec4(a.xyz, size));
    put(hdr + 2u + DIFFUSE_VEC4S * at, vec4(b.xyz, c.y + fade));
}
