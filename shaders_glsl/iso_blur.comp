#version 460
//! iso_blur — the smoothed iso field (`[iso] smoothing` > 0): a separable Gaussian blur of the colour field φ on
//! the lattice `iso_volume` filled, one axis per dispatch (zero outside the lattice), and in the last dispatch
//! the blend F = φ + w(c̄) (G_σ ∗ φ − φ), w = smoothstep of c̄ over [bulk0, bulk1]: calm water (full
//! neighbourhoods) takes the blurred field, spray and thin sheets keep the raw one. Measured on the shared
//! dam-break frame by the prototype tools/quality-volume.py before it was built here. CPU reference:
//! smooth_volume in src/surface/iso/field.rs.
//! Bricks (ISO_VOLUME_BRICK³ voxels): a voxel whose brick has no occupied brick (iso_volume marks them) within
//! the blur's reach on any axis is 0 after every pass, exactly, so it is written without reading anything; the
//! ISO_BLUR_BRICKS dispatch (first) turns the occupied flags into those active flags (most of a splash's box is
//! air: the dam-break frame's blur 1.13 → 0.54–0.62 s on lavapipe together with the division-free indexing,
//! docs/iso-surface.md, commit e679baa).
//! ISO_BLUR_BRICKS: in/out: bricks (binding 1: occupied flags, then the active flags written after them).
//! ISO_BLUR_FIRST (x): in: acc (binding 1, R32UI: φ fixed point at 2v), bricks (3, R32UI); out: binding 2.
//! Middle (y): in: binding 1 (R32F), bricks (3); out: binding 2.
//! ISO_BLUR_LAST (z): in: binding 1 (R32F), acc (binding 2, R32UI: φ and Σ W c / n), bricks (4); out: F (3).
#include "common.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(push_constant) uniform BlurPush {
    uvec4 dims;   // xyz: voxels per axis, w: the axis this dispatch blurs (0, 1, 2)
    vec4 params;  // x: 1 / (2 σ²) in voxels², y: taps either side, z, w: bulk0, bulk1
} pc;

#ifdef ISO_BLUR_BRICKS
layout(std430, set = 0, binding = 1) buffer Bricks { uint bricks[]; };
#elif defined(ISO_BLUR_FIRST)
layout(set = 0, binding = 1) uniform usamplerBuffer src_t;
#define SRC(i) (float(texelFetch(src_t, 2 * (i)).x) * (1.0 / float(1u << ISO_VOLUME_FIX_BITS)))
#else
layout(set = 0, binding = 1) uniform samplerBuffer src_t;
#define SRC(i) texelFetch(src_t, (i)).x
#endif
#ifdef ISO_BLUR_LAST
layout(set = 0, binding = 2) uniform usamplerBuffer acc_t;
layout(std430, set = 0, binding = 3) writeonly buffer Dst { float dst[]; };
layout(set = 0, binding = 4) uniform usamplerBuffer bricks_t;
#elif !defined(ISO_BLUR_BRICKS)
layout(std430, set = 0, binding = 2) writeonly buffer Dst { float dst[]; };
layout(set = 0, binding = 3) uniform usamplerBuffer bricks_t;
#endif

#ifdef ISO_BLUR_BRICKS
void main() {
    ivec3 bd = (ivec3(pc.dims.xyz) + int(ISO_VOLUME_BRICK) - 1) / int(ISO_VOLUME_BRICK);
    int nb = bd.x * bd.y * bd.z;
    int b = int(gl_GlobalInvocationID.x);
    if (b >= nb) return;
    ivec3 c = ivec3(b % bd.x, (b / bd.x) % bd.y, b / (bd.x * bd.y));
    int reach = (int(pc.params.y) + int(ISO_VOLUME_BRICK) - 1) / int(ISO_VOLUME_BRICK);
    ivec3 lo = max(c - reach, ivec3(0)), hi = min(c + reach, bd - 1);
    uint any_ = 0u;
    for (int z = lo.z; z <= hi.z; ++z)
        for (int y = lo.y; y <= hi.y; ++y)
            for (int x = lo.x; x <= hi.x; ++x) any_ |= bricks[x + bd.x * (y + bd.y * z)];
    bricks[nb + b] = any_;
}
#else

void main() {
    // One invocation per voxel, dispatched over (x / LOCAL_1D, y, z): no integer division per voxel (lavapipe
    // runs those lane by lane; with them the blur cost 1.1 s on the dam-break frame).
    ivec3 d = ivec3(pc.dims.xyz);
    ivec3 p = ivec3(gl_GlobalInvocationID);
    if (p.x >= d.x) return;
    int v = p.x + d.x * (p.y + d.y * p.z);
    int axis = int(pc.dims.w);
    int stride = axis == 0 ? 1 : (axis == 1 ? d.x : d.x * d.y);
    int n = d[axis], c = p[axis];
    uint B = uint(ISO_VOLUME_BRICK);
    uvec3 bd = (uvec3(d) + B - 1u) / B, pb = uvec3(p) / B;
    if (texelFetch(bricks_t, int(bd.x * bd.y * bd.z + pb.x + bd.x * (pb.y + bd.y * pb.z))).x == 0u) {
        dst[v] = 0.0;
        return;
    }
    // Taps exp(−t² a) by recurrence: w(t + 1) = w(t) e^{−(2t + 1) a}.
    int k = int(pc.params.y);
    float sum = SRC(v), total = 1.0, w = 1.0, m = exp(-pc.params.x), r = exp(-2.0 * pc.params.x);
    for (int t = 1; t <= k; ++t) {
        w *= m;
        m *= r;
        total += 2.0 * w;
        if (c - t >= 0) sum += w * SRC(v - t * stride);
        if (c + t < n) sum += w * SRC(v + t * stride);
    }
    float blurred = sum / total;
#ifdef ISO_BLUR_LAST
    uvec2 a = uvec2(texelFetch(acc_t, 2 * v).x, texelFetch(acc_t, 2 * v + 1).x);
    float phi = float(a.x) * (1.0 / float(1u << ISO_VOLUME_FIX_BITS));
    float cbar = a.x > 0u ? float(a.y) / float(a.x) : 0.0;
    float b0 = pc.params.z, b1 = pc.params.w;
    dst[v] = phi + (b1 > b0 ? smoothstep(b0, b1, cbar) : 1.0) * (blurred - phi);
#else
    dst[v] = blurred;
#endif
}
#endif
