#version 460
//! sim_diffuse_draw — per pool slot: the `diffuse` pass's two vec4 (position and billboard radius; velocity and
//! kind + fade) written into the renderer's particle buffer after the fluid's positions and motions; a free slot
//! writes zeros (fade 0: the pass skips it). passes::diffuse::encode, on the GPU.
//! In: pool. Out: the particle buffer's diffuse region.
#include "sim_diffuse.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, binding = 1) readonly buffer Pool { vec4 pool[]; };
layout(std430, binding = 2) writeonly buffer Out { vec4 particles[]; };

float ramp(float t, float over) { return over > 0.0 ? t / over : 1.0; }

void main() {
    uint k = gl_GlobalInvocationID.x;
    if (k >= pc.slots) return;
    vec4 a = pool[3u * k];
    uint o = pc.out_offset + 2u * k;
    if (!(a.w > 0.0)) {
        particles[o] = vec4(0.0);
        particles[o + 1u] = vec4(0.0);
        return;
    }
    vec4 b = pool[3u * k + 1u];
    vec4 c = pool[3u * k + 2u];
    float u = unit(hash4(floatBitsToUint(c.x), 0x5eedu, 0u, 0u));
    float size = pc.size * pc.radius * (1.0 + pc.size_spread * (2.0 * u - 1.0));
    float fade = clamp(min(ramp(a.w, pc.fade), ramp(b.w, pc.fade_in)), 1e-3, 0.999);
    particles[o] = vec4(a.xyz, size);
    particles[o + 1u] = vec4(b.xyz, c.y + fade);
}
