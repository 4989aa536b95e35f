#version 460
//! iso_blur — the smoothed iso field (`[iso] smoothing` > 0): a separable Gaussian blur of the colour field φ on
//! the lattice `iso_volume` filled, one axis per dispatch (zero outside the lattice), and in the last dispatch
//! the blend F = φ + w(c̄) (G_σ ∗ φ − φ), w = smoothstep of c̄ over [bulk0, bulk1]: calm water (full
//! neighbourhoods) takes the blurred field, spray and thin sheets keep the raw one. Measured on the shared
//! dam-break frame by the prototype tools/quality-volume.py before it was built here. CPU reference:
//! smooth_volume in src/iso.rs.
//! ISO_BLUR_FIRST (x): in: acc (binding 1, R32UI: φ fixed point at 2v); out: binding 2.
//! Middle (y): in: binding 1 (R32F); out: binding 2.
//! ISO_BLUR_LAST (z): in: binding 1 (R32F), acc (binding 2, R32UI: φ and Σ W c / n); out: F (binding 3).
#include "common.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(push_constant) uniform BlurPush {
    uvec4 dims;   // xyz: voxels per axis, w: the axis this dispatch blurs (0, 1, 2)
    vec4 params;  // x: 1 / (2 σ²) in voxels², y: taps either side, z, w: bulk0, bulk1
} pc;

#ifdef ISO_BLUR_FIRST
layout(set = 0, binding = 1) uniform usamplerBuffer src_t;
#define SRC(i) (float(texelFetch(src_t, 2 * (i)).x) * (1.0 / float(1u << ISO_VOLUME_FIX_BITS)))
#else
layout(set = 0, binding = 1) uniform samplerBuffer src_t;
#define SRC(i) texelFetch(src_t, (i)).x
#endif
#ifdef ISO_BLUR_LAST
layout(set = 0, binding = 2) uniform usamplerBuffer acc_t;
layout(std430, set = 0, binding = 3) writeonly buffer Dst { float dst[]; };
#else
layout(std430, set = 0, binding = 2) writeonly buffer Dst { float dst[]; };
#endif

void main() {
    ivec3 d = ivec3(pc.dims.xyz);
    // 2D groups past 65535 (the guaranteed limit per axis): rows of gl_NumWorkGroups.x groups.
    int v = int(gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * LOCAL_1D);
    if (v >= d.x * d.y * d.z) return;
    int axis = int(pc.dims.w);
    int stride = axis == 0 ? 1 : (axis == 1 ? d.x : d.x * d.y);
    int n = axis == 0 ? d.x : (axis == 1 ? d.y : d.z);
    int c = (v / stride) % n;
    int k = int(pc.params.y);
    float total = 0.0, sum = 0.0;
    for (int t = -k; t <= k; ++t) {
        float w = exp(-float(t * t) * pc.params.x);
        total += w;
        if (c + t >= 0 && c + t < n) sum += w * SRC(v + t * stride);
    }
    float blurred = sum / total;
#ifdef ISO_BLUR_LAST
    uvec2 a = uvec2(texelFetch(acc_t, 2 * v).x, texelFetch(acc_t, 2 * v + 1).x);
    float phi = float(a.x) * (1.0 / float(1u << ISO_VOLUME_FIX_BITS));
    float cbar = a.x > 0u ? float(a.y) / float(a.x) : 0.0;
    float b0 = pc.params.z, b1 = pc.params.w;
    float t = b1 > b0 ? clamp((cbar - b0) / (b1 - b0), 0.0, 1.0) : 1.0;
    dst[v] = phi + t * t * (3.0 - 2.0 * t) * (blurred - phi);
#else
    dst[v] = blurred;
#endif
}
