#version 460
// The work counters' subgroup sums (work_count.glsl).
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#if defined(ISO_VOLUME_DEPOSIT64)
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
#endif
//! iso_volume — builds the sparse lattice of the smoothed iso field (`[iso] smoothing` > 0) once per set of
//! particles, after iso_density (which gives each sorted point j its weight 1/n_j and its neighbour count c_j =
//! Σ_{k≠j} max(0, 1 − |x_j − x_k|²/h²), splashsurf's feature weight, Löschner et al. 2023). Three dispatches:
//! ISO_VOLUME_MARK — per point, every brick within its deposit's reach + 1 voxel is marked in the table (zeroed
//!     by the host);
//! ISO_VOLUME_ALLOC — per table entry, a marked brick takes the next pool index (an atomic counter: the pool's
//!     order varies between runs, the values at each voxel do not) and lists its coordinates; the header
//!     counts them;
//! (plain) — per point, its mass M_j = I_W h³/n_j (I_W = π/8, the integral of the unnormalised cubic spline)
//!     spread over the voxels within R_j by the smooth kernel K(d) = (1 − d²/R_j²)³ / (0.6383 R_j³) (C² where
//!     it ends), and M_j c_j likewise; R_j is wider where the point's lattice order o_j (iso_density) is high
//!     (`[iso] lattice_smoothing`: a lattice's terraces are wider than a liquid's bumps): B(v) = Σ_j M_j K(|v − x_j|) is the blurred colour field sampled at the
//!     voxel, B c̄ its neighbour count interpolated (Shepard). Fixed point (ISO_VOLUME_FIX_BITS), integer
//!     atomics: the same sums in any order, on any device. ISO_VOLUME_DEPOSIT64 (devices with
//!     shaderBufferInt64Atomics) adds both sums of a voxel with one 64-bit atomic — the pair is one
//!     little-endian uint64 (B in the low word, B c̄ in the high), and no low sum reaches 2³² (B < 4096 at
//!     ISO_VOLUME_FIX_BITS = 20; the colour field is about 1 inside water), so no carry crosses: the same words as two 32-bit atomics, half the atomics;
//! ISO_VOLUME_APRON — per stored voxel of the allocated bricks, the apron copied from the neighbour brick
//!     (iso_volume.glsl).
//! R is chosen so K's per-axis variance (R²/11) plus the cast's quadratic B-spline read (s²/4) equals the
//! smoothing asked for, σ² + 0.075 h² (Gaussian ∗ cubic spline, per axis): one smooth kernel stands for the
//! whole blur, so no separate blur pass, and the lattice can be as coarse as that smooth field allows. A
//! trilinear (cloud-in-cell) deposit with a separate blur was cheaper (8 voxels per point) but its weights
//! depend on where a point lies within its voxel: a tilted lattice of particles came out with 3° normal steps
//! (tests/gpu_passes.rs, the seam test; docs/iso-surface.md).
//! CPU reference: VolumeShape::{marked, deposit} in src/field/iso/mod.rs.
//! MARK in: points (1). In/out: table (2). ALLOC in/out: table (1), header (2: {0, 1, 1, bricks}, zeroed by the
//! host); out: coordinates (3, x | y << 11 | z << 22). Plain in: points (1), c (2), table (3); in/out: the sums
//! (4, two uints per stored voxel, zeroed by the host), which the cast reads, and the work counts (5). APRON in: table (1), coordinates
//! (2), header (3); in/out: the sums (4).
#include "common.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(push_constant) uniform VolPush {
    vec4 origin;  // xyz: voxel (0, 0, 0) (world), w: voxel spacing s
    uvec4 bdims;  // xyz: bricks per axis (the table), w: the pool's capacity (bricks)
    vec4 params;  // x: the deposit's scale I_W h³ / (0.6383 R³) and y: R (voxels) of the least ordered point,
                  // z: ⌈R⌉ of the widest (the bricks marked), w: R of the most ordered point (voxels)
    uvec4 misc;   // x: points
} pc;

#if defined(ISO_VOLUME_MARK)
layout(set = 0, binding = 1) uniform samplerBuffer points_t;
layout(std430, set = 0, binding = 2) buffer Table { uint table[]; };
#define ISO_TABLE(i) table[i]
#elif defined(ISO_VOLUME_ALLOC)
layout(std430, set = 0, binding = 1) buffer Table { uint table[]; };
layout(std430, set = 0, binding = 2) buffer Header { uint header[4]; };
layout(std430, set = 0, binding = 3) writeonly buffer Coords { uint coords[]; };
#define ISO_TABLE(i) table[i]
#elif defined(ISO_VOLUME_APRON)
layout(set = 0, binding = 1) uniform usamplerBuffer table_t;
layout(set = 0, binding = 2) uniform usamplerBuffer coords_t;
layout(set = 0, binding = 3) uniform usamplerBuffer header_t;
layout(std430, set = 0, binding = 4) buffer Acc { uvec2 acc[]; };
#define ISO_TABLE(i) texelFetch(table_t, int(i)).x
#else
layout(set = 0, binding = 1) uniform samplerBuffer points_t;
layout(set = 0, binding = 2) uniform samplerBuffer counts_t;
layout(set = 0, binding = 3) uniform usamplerBuffer table_t;
#if defined(ISO_VOLUME_DEPOSIT64)
layout(std430, set = 0, binding = 4) buffer Acc { uint64_t acc[]; };
#else
layout(std430, set = 0, binding = 4) buffer Acc { uvec2 acc[]; };
#endif
// The deposit's work (bench's `iso_volume_work`): [0] voxel deposits (point–voxel pairs; one 64-bit atomic
// each, or two 32-bit ones), zeroed by the host.
layout(std430, set = 0, binding = 5) buffer VolWork { uint vol_work[4]; };
// No frame block here: the deposits are counted whenever the field is built (once per particle set).
#define WORK_ALWAYS
#include "work_count.glsl"
#define ISO_TABLE(i) texelFetch(table_t, int(i)).x
#endif
#include "iso_volume.glsl"

#if !defined(ISO_VOLUME_ALLOC) && !defined(ISO_VOLUME_APRON)
/// Lattice coordinates of point j, clamped a voxel outside the table (a stray point far from the water marks
/// and deposits nothing).
vec3 lattice_pos(uint j, ivec3 bd) {
    vec3 u = (texelFetch(points_t, int(j)).xyz - pc.origin.xyz) / pc.origin.w;
    return clamp(u, vec3(-2.0), vec3(bd * int(ISO_VOLUME_BRICK) + 2));
}
#endif

#if defined(ISO_VOLUME_MARK)
void main() {
    uint j = gl_GlobalInvocationID.x;
    if (j >= pc.misc.x) return;
    ivec3 bd = ivec3(pc.bdims.xyz);
    ivec3 g = ivec3(floor(lattice_pos(j, bd)));
    int t = int(pc.params.z) + 1;  // the deposit's reach and a voxel: the cast's 3³ read around any voxel it can
                                   // touch is then in an allocated brick
    ivec3 b0 = max((g - t) >> 3, ivec3(0)), b1 = min((g + 1 + t) >> 3, bd - 1);
    for (int z = b0.z; z <= b1.z; ++z)
        for (int y = b0.y; y <= b1.y; ++y)
            for (int x = b0.x; x <= b1.x; ++x) table[x + bd.x * (y + bd.y * z)] = 1u;
}
#elif defined(ISO_VOLUME_ALLOC)
void main() {
    uint b = gl_GlobalInvocationID.x;
    if (b == 0u) { header[1] = 1u; header[2] = 1u; }
    uvec3 bd = pc.bdims.xyz;
    if (b >= bd.x * bd.y * bd.z || table[b] == 0u) return;
    uint i = atomicAdd(header[3], 1u);
    if (i >= pc.bdims.w) {
        // Over capacity: the host sized the pool from the same rule, so only a GPU-written set of particles can
        // get here (it reads the count and grows the pool). Read as 0, but not skipped as empty by the cast.
        table[b] = ISO_UNSTORED;
        return;
    }
    table[b] = i + 1u;
    coords[i] = (b % bd.x) | (((b / bd.x) % bd.y) << 11) | ((b / (bd.x * bd.y)) << 22);
}
#elif defined(ISO_VOLUME_APRON)
void main() {
    // One invocation per stored voxel of the pool's allocated bricks; only the apron's copy anything.
    uint id = gl_GlobalInvocationID.x;
    uint brick = id / uint(ISO_STORE_VOXELS), k = id % uint(ISO_STORE_VOXELS);
    if (brick >= min(texelFetch(header_t, 3).x, pc.bdims.w)) return;
    ivec3 t = ivec3(k % 10u, (k / 10u) % 10u, k / 100u);
    if (all(greaterThanEqual(t, ivec3(1))) && all(lessThanEqual(t, ivec3(8)))) return;
    uint bc = texelFetch(coords_t, int(brick)).x;
    ivec3 g = ivec3(bc & 2047u, (bc >> 11) & 2047u, bc >> 22) * int(ISO_VOLUME_BRICK) + t - 1;
    uint src = iso_voxel_slot(g, ivec3(pc.bdims.xyz));
    acc[id] = src == ISO_NONE ? uvec2(0u) : acc[src];
}
#else
void main() {
    uint j = gl_GlobalInvocationID.x;
    if (j >= pc.misc.x) return;
    ivec3 bd = ivec3(pc.bdims.xyz);
    vec3 u = lattice_pos(j, bd);
    // The deposit kernel's radius R (voxels): R² blended from the least ordered point's to the most ordered's
    // by this point's lattice order, its scale by (R0 / R)³ (VolumeParams::deposit_radius, point_radius).
    vec2 co = texelFetch(counts_t, int(j)).xy;
    float r0 = pc.params.y, r1 = pc.params.w;
    float rv = sqrt(r0 * r0 + clamp(co.y, 0.0, 1.0) * (r1 * r1 - r0 * r0));
    float ratio = r0 / rv;
    ivec3 lo = ivec3(ceil(u - rv)), hi = ivec3(floor(u + rv));
    float inv_r2 = 1.0 / (rv * rv);
    float m = pc.params.x * (ratio * ratio * ratio) * texelFetch(points_t, int(j)).w * float(1u << ISO_VOLUME_FIX_BITS);
    float c = co.x;
    uint deposits = 0u;
    for (int z = lo.z; z <= hi.z; ++z) {
        for (int y = lo.y; y <= hi.y; ++y) {
            for (int x = lo.x; x <= hi.x; ++x) {
                vec3 d = vec3(x, y, z) - u;
                float q = 1.0 - dot(d, d) * inv_r2;
                if (q <= 0.0) continue;
                uint slot = iso_voxel_slot(ivec3(x, y, z), bd);
                if (slot == ISO_NONE) continue;
                float w = q * q * q * m;
                ++deposits;
#if defined(ISO_VOLUME_DEPOSIT64)
                atomicAdd(acc[slot], uint64_t(uint(w + 0.5)) | (uint64_t(uint(w * c + 0.5)) << 32));
#else
                atomicAdd(acc[slot].x, uint(w + 0.5));
                atomicAdd(acc[slot].y, uint(w * c + 0.5));
#endif
            }
        }
    }
    WORK_ADD(vol_work[0], deposits);
}
#endif
