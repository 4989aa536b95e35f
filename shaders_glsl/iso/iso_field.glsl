//! iso_field.glsl — the SPH colour field φ(x) = Σ_j W(|x − x_j|) / n_j on the uniform grid built at upload
//! (src/field/iso/mod.rs, which holds the CPU reference of everything here). Shared by `iso_density` and `iso`.
//! Binding 1: the points sorted by cell: (xyz, 1/n_j) in the casts (`weighted`, iso_density's output), xyz in
//! iso_density and the anisotropy pass (`points`); binding 2: cells (first point, count; in the casts,
//! ISO_CELL_EMPTY, iso_empty's copy with each cell's empty distance in the count's top bits); with
//! ISO_WRITES_WEIGHTS (iso_density) binding 3: the weighted points it writes. The casts read a point and its
//! weight with one fetch (iso 7 % cheaper than a separate weight buffer on lavapipe). Every array the loops
//! read at a per-point index is a texel buffer (Buffer::with_texel_view says why: on lavapipe a
//! storage-buffer load there is a loop over the lanes). ISO_NO_WEIGHTS: no iso_sum (the anisotropy pass).
//! With ISO_ANISO_BINDING defined (iso_aniso.comp), each point's anisotropic kernel (the `anisotropy` pass,
//! Yu & Turk 2013): φ(x) = Σ_j det(M_j) W(|M_j (x − c_j)| / h) / n_j.
//! With ISO_VOLUME defined (iso_vol.comp: `[iso] smoothing` > 0), the cast's sample blends the exact field with
//! the smoothed one read from the sparse lattice iso_volume wrote (binding 7: its brick table, 8: its voxels,
//! RG32UI fixed point: B and B c̄; iso_volume.glsl): F = φ + w(c̄) (B − φ), the exact sum only where w < 1.

layout(set = 0, binding = 1) uniform samplerBuffer iso_points_t;   // RGBA32F
layout(set = 0, binding = 2) uniform usamplerBuffer iso_cells_t;   // RG32UI
#define ISO_POINT(i) texelFetch(iso_points_t, int(i))
#ifdef ISO_CELL_EMPTY
// The casts read iso_empty's copy of the cell table: each cell's empty distance E in the count's top bits.
const uint ISO_COUNT_MASK = 0xffffffffu >> ISO_EMPTY_BITS;
#define ISO_CELL(i) (texelFetch(iso_cells_t, int(i)).xy & uvec2(0xffffffffu, ISO_COUNT_MASK))
#else
#define ISO_CELL(i) texelFetch(iso_cells_t, int(i)).xy
#endif
#ifdef ISO_VOLUME
layout(set = 0, binding = 7) uniform usamplerBuffer iso_table_t;   // R32UI per brick: 0, pool index + 1 or ISO_UNSTORED
layout(set = 0, binding = 8) uniform usamplerBuffer iso_volume_t;  // RG32UI per voxel: (B, B c̄), fixed point
#define ISO_TABLE(i) texelFetch(iso_table_t, int(i)).x
#include "iso_volume.glsl"
#endif
#ifdef ISO_WRITES_WEIGHTS
layout(std430, set = 0, binding = 3) writeonly buffer IsoWeighted { vec4 iso_weighted_out[]; };
layout(std430, set = 0, binding = 4) writeonly buffer IsoCounts { vec2 iso_counts_out[]; };
#endif

#ifdef ISO_ANISO_BINDING
layout(set = 0, binding = ISO_ANISO_BINDING) uniform samplerBuffer iso_aniso_t;   // RGBA32F
#define ISO_ANISO(i) texelFetch(iso_aniso_t, int(i))
#endif

layout(push_constant) uniform IsoPush {
    vec4 origin;  // xyz: grid origin (world), w: cell size (≥ support)
    uvec4 dims;   // xyz: cells per axis, w: point count
    vec4 params;  // x: kernel support h, y: iso threshold, z: smallest step, w: bound radius (world units)
    uvec4 steps;  // x: most march steps, y: bisection iterations, z: the back image bounds the march per pixel
                  // (1) or per 8×8 tile (2)
    vec4 aniso;   // anisotropy: x: k_r, y: N_ε, z: centre blend λ, w: longest centre move (world units);
                  // the smoothed field's lattice (iso_vol): xyz voxel (0, 0, 0), w: voxel spacing
    vec4 aniso2;  // anisotropy: x: longest axis (units of h), z: neighbourhood radius (world units); the
                  // lattice: yzw bricks per axis (exact as floats)
    vec4 fine;    // coarse-to-fine (iso_cast.glsl): x: particle radius ÷ its least radius on screen in pixels
                  // (0: off), y: iso_fine's phase / iso_rest's round, z: the widest depth spread of the
                  // marched neighbours, w: the longest Newton step (both world units)
    vec4 volume;  // the smoothed field (iso_vol): xy: the bulk ramp of c̄, z: the bound of |∇B| (1 / world units)
} pc;

/// Cubic spline without its constant (it cancels in φ); q = distance / support.
float iso_kernel(float q) {
    if (q <= 0.5) return 1.0 - 6.0 * q * q + 6.0 * q * q * q;
    if (q < 1.0) { float a = 1.0 - q; return 2.0 * a * a * a; }
    return 0.0;
}

#if !defined(ISO_NO_WEIGHTS)
/// Runs VISIT(i, pt, v, d2) for every point i of the 3×3×3 cells around x: pt its texel (xyz, 1/n_j), v = pt.xyz
/// − x, d2 = |v|². Cells are x fastest and their points contiguous, so each of the 9 rows of 3 cells is one range
/// of points (9 cell-table pairs of reads instead of 27 lookups: the `iso` pass 198 → 127 ms on lavapipe, dam
/// break 960×540). A macro, not a function taking a callback (GLSL has none), shared by iso_sum and
/// iso_sum_grad.
#define ISO_FOR_POINTS(x, VISIT)                                                                  \
    {                                                                                            \
        ivec3 c_ = ivec3(floor(((x) - pc.origin.xyz) / pc.origin.w));                             \
        ivec3 dims_ = ivec3(pc.dims.xyz);                                                        \
        int x0_ = max(c_.x - 1, 0), x1_ = min(c_.x + 1, dims_.x - 1);                            \
        if (x0_ <= x1_) {                                                                        \
            for (int z_ = max(c_.z - 1, 0); z_ <= min(c_.z + 1, dims_.z - 1); ++z_) {            \
                for (int y_ = max(c_.y - 1, 0); y_ <= min(c_.y + 1, dims_.y - 1); ++y_) {        \
                    int row_ = dims_.x * (y_ + dims_.y * z_);                                    \
                    uint first_ = ISO_CELL(x0_ + row_).x;                                        \
                    uvec2 last_ = ISO_CELL(x1_ + row_);                                          \
                    for (uint i_ = first_; i_ < last_.x + last_.y; ++i_) {                       \
                        vec4 pt_ = ISO_POINT(i_);                                                \
                        vec3 v_ = pt_.xyz - (x);                                                 \
                        VISIT(i_, pt_, v_, dot(v_, v_));                                         \
                    }                                                                            \
                }                                                                                \
            }                                                                                    \
        }                                                                                        \
    }

/// Σ W(|x − x_j|) (weighted by 1/n_j when `weighted`) over the 3×3×3 cells around x; `dmin`: the distance
/// to the nearest point, capped at the cell size (no point in the 27 cells is at least that far), or in the
/// casts (ISO_CELL_EMPTY) the empty distance's bound where the 27 cells are empty.
float iso_sum_points(vec3 x, bool weighted, out float dmin) {
#ifdef ISO_CELL_EMPTY
    // In a cell whose empty distance E is at least 2 the 27 cells are empty (φ = 0) and every point is at least
    // E − 1 cells away (iso_empty.comp).
    ivec3 ce = ivec3(floor((x - pc.origin.xyz) / pc.origin.w));
    if (all(greaterThanEqual(ce, ivec3(0))) && all(lessThan(ce, ivec3(pc.dims.xyz)))) {
        uint e = texelFetch(iso_cells_t, ce.x + int(pc.dims.x) * (ce.y + int(pc.dims.y) * ce.z)).y >> (32u - ISO_EMPTY_BITS);
        if (e >= 2u) {
            dmin = float(e - 1u) * pc.origin.w;
            return 0.0;
        }
    }
#endif
    float s = 0.0;
    float d2min = pc.origin.w * pc.origin.w;
    float inv_h = 1.0 / pc.params.x;
#ifdef ISO_ANISO_BINDING
    // Weighted always (iso_aniso.comp only casts). The ellipsoid lies inside the ball of radius (longest axis)
    // around its centre.
    float reach = pc.params.x * pc.aniso2.x;
#define ISO_SUM_VISIT(i, pt, v, d2)                                                              \
    {                                                                                            \
        float e2_ = d2;                                                                          \
        d2min = min(d2min, e2_);                                                                 \
        vec4 a0_ = ISO_ANISO(3u * i);                                                            \
        vec3 u_ = x - a0_.xyz;                                                                   \
        if (dot(u_, u_) < reach * reach) {                                                       \
            vec4 a1_ = ISO_ANISO(3u * i + 1u), a2_ = ISO_ANISO(3u * i + 2u);                     \
            mat3 m_ = mat3(a1_.x, a1_.y, a1_.z, a1_.y, a1_.w, a2_.x, a1_.z, a2_.x, a2_.y);       \
            s += a0_.w * iso_kernel(length(m_ * u_) * inv_h) * pt.w;                             \
        }                                                                                        \
    }
#else
#define ISO_SUM_VISIT(i, pt, v, d2)                                                              \
    {                                                                                            \
        float e2_ = d2;                                                                          \
        d2min = min(d2min, e2_);                                                                 \
        float w_ = iso_kernel(sqrt(e2_) * inv_h);                                                \
        s += weighted ? w_ * pt.w : w_;                                                          \
    }
#endif
    ISO_FOR_POINTS(x, ISO_SUM_VISIT)
#undef ISO_SUM_VISIT
    dmin = sqrt(d2min);
    return s;
}

#ifdef ISO_VOLUME
/// The lattice's (B, B c̄) at x: the quadratic B-spline over the 3³ voxels around the voxel nearest it (C¹:
/// the surface's normals do not crease at voxel faces, as trilinear reads made them); 0 where that voxel's
/// brick is not allocated (iso_volume marks every brick within a voxel of a nonzero one). The 3³ voxels are
/// all in that brick's stored apron: one table lookup, 27 fetches. Measured on the dam-break frame at the
/// sequence's camera (960×540, lavapipe, 8 samples per ray at most): 224 ms with a table lookup per tap's
/// brick, more than the exact field's sum (148 ms).
/// `gap`: where that brick lies inside the table but is not allocated, a lower bound of the distance from x to
/// every point (world units; else 0). iso_volume marks every brick within the deposit's reach + 1 voxel of a
/// point's voxel, so each point lies more than pc.volume.w voxels (VolumeShape::empty_reach) beyond the box of
/// positions whose nearest voxel is in an unmarked brick, along some axis: at least that plus x's depth inside
/// the box away. The field is 0 there (the support is shorter), and the march skips by the gap instead of the
/// exact sum's nearest point (which sees at most a cell, one support, away): the long rays from spray to the
/// water behind it cross empty bricks in a few samples (CPU reference: VolumeShape::gap).
vec2 iso_volume_at(vec3 x, out float gap) {
    vec3 u = (x - pc.aniso.xyz) / pc.aniso.w;
    vec3 c = floor(u + 0.5);
    vec3 t = u - c;
    ivec3 bd = ivec3(pc.aniso2.yzw);
    ivec3 g = ivec3(clamp(c, vec3(-8.0), vec3(bd * int(ISO_VOLUME_BRICK) + 8)));
    ivec3 brick = g >> 3;
    uint entry = iso_brick_entry(brick, bd);
    uint base = iso_entry_base(entry);
    gap = 0.0;
    if (base == ISO_NONE) {
        // A gap only where the brick lies in the table unmarked (entry 0; outside the table, or a marked brick
        // the pool had no room for, reads 0 without one).
        if (entry == 0u) {
            vec3 lo = vec3(brick * int(ISO_VOLUME_BRICK)) - 0.5;
            vec3 depth_in = min(u - lo, lo + float(ISO_VOLUME_BRICK) - u);
            gap = (min(depth_in.x, min(depth_in.y, depth_in.z)) + pc.volume.w) * pc.aniso.w;
        }
        return vec2(0.0);
    }
    vec3 a = 0.5 - t, b = 0.5 + t;
    mat3 w = mat3(0.5 * a * a, 0.75 - t * t, 0.5 * b * b);
    int o = int(base) + iso_store_index(g & 7);  // the footprint's first voxel: storage coordinate (g & 7) − 1 + 1
    vec2 s = vec2(0.0);
    for (int z = 0; z < 3; ++z) {
        for (int y = 0; y < 3; ++y) {
            int r = o + ISO_STORE * (y + ISO_STORE * z);
            vec2 row = w[0].x * vec2(texelFetch(iso_volume_t, r).xy) + w[1].x * vec2(texelFetch(iso_volume_t, r + 1).xy) +
                       w[2].x * vec2(texelFetch(iso_volume_t, r + 2).xy);
            s += (w[y].y * w[z].z) * row;
        }
    }
    return s * (1.0 / float(1u << ISO_VOLUME_FIX_BITS));
}

/// The cast's field sample F = φ + w(c̄) (B − φ), and how far the march may skip (as `dmin`: the march steps
/// by dmin − bound, at least its smallest step). In an unallocated brick F = 0 and the skip is its gap.
/// Where w < 1 the exact sum gives the nearest point's distance, as iso.comp skips by (the smoothed part
/// there is thin water's: it does not reach past the bound spheres). Where w = 1, F = B, whose gradient is
/// at most pc.volume.z (ISO_VOLUME_LIPSCHITZ / R), so no crossing lies nearer than (threshold − B) / that.
float iso_sum(vec3 x, bool weighted, out float dmin) {
    float gap;
    vec2 bc = iso_volume_at(x, gap);
    if (gap > 0.0) {
        dmin = gap;
        return 0.0;
    }
    float cbar = bc.x > 0.0 ? bc.y / bc.x : 0.0;
    float w = pc.volume.y > pc.volume.x ? smoothstep(pc.volume.x, pc.volume.y, cbar) : 1.0;
    if (w >= 1.0) {
        dmin = pc.params.w + max(pc.params.y - bc.x, 0.0) / pc.volume.z;
        return bc.x;
    }
    float phi = iso_sum_points(x, true, dmin);
    return phi + w * (bc.x - phi);
}
#else
#define iso_sum iso_sum_points
#endif

#ifndef ISO_ANISO_BINDING
/// The weighted field φ(x) and its gradient (isotropic kernel): ∇W(|x − x_j| / h) = W'(q) / q · (x − x_j) / h²,
/// with W'(q) / q = −12 + 18 q (q ≤ ½) or −6 (1 − q)² / q (½ < q < 1). For the `iso` pass's Newton step
/// (iso_fine.comp).
float iso_sum_grad(vec3 x, out vec3 grad) {
    float s = 0.0;
    vec3 g = vec3(0.0);
    float inv_h = 1.0 / pc.params.x;
#define ISO_GRAD_VISIT(i, pt, v, d2)                                                             \
    {                                                                                            \
        float q_ = max(sqrt(d2) * inv_h, 1e-6);                                                  \
        float a_ = max(1.0 - q_, 0.0);                                                           \
        bool inner_ = q_ <= 0.5;                                                                 \
        float w_ = inner_ ? 1.0 - 6.0 * q_ * q_ + 6.0 * q_ * q_ * q_ : 2.0 * a_ * a_ * a_;        \
        float dq_ = inner_ ? -12.0 + 18.0 * q_ : -6.0 * a_ * a_ / q_;                             \
        s += w_ * pt.w;                                                                          \
        g -= (dq_ * pt.w) * v;                                                                   \
    }
    ISO_FOR_POINTS(x, ISO_GRAD_VISIT)
#undef ISO_GRAD_VISIT
    grad = g * (inv_h * inv_h);
    return s;
}
#endif
#endif
