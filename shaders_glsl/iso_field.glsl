//! iso_field.glsl — the SPH colour field φ(x) = Σ_j W(|x − x_j|) / n_j on the uniform grid built at upload
//! (src/iso.rs, which holds the CPU reference of everything here). Shared by `iso_density` and `iso`.
//! Binding 1: the points sorted by cell: (xyz, 1/n_j) in the casts (`weighted`, iso_density's output), xyz in
//! iso_density and the anisotropy pass (`points`); binding 2: cells (first point, count); with
//! ISO_WRITES_WEIGHTS (iso_density) binding 3: the weighted points it writes. The casts read a point and its
//! weight with one fetch (iso 7 % cheaper than a separate weight buffer on lavapipe). Every array the loops
//! read at a per-point index is a texel buffer (Buffer::with_texel_view says why: on lavapipe a
//! storage-buffer load there is a loop over the lanes). ISO_NO_WEIGHTS: no iso_sum (the anisotropy pass).
//! With ISO_ANISO_BINDING defined (iso_aniso.comp), each point's anisotropic kernel (the `anisotropy` pass,
//! Yu & Turk 2013): φ(x) = Σ_j det(M_j) W(|M_j (x − c_j)| / h) / n_j.

layout(set = 0, binding = 1) uniform samplerBuffer iso_points_t;   // RGBA32F
layout(set = 0, binding = 2) uniform usamplerBuffer iso_cells_t;   // RG32UI
#define ISO_POINT(i) texelFetch(iso_points_t, int(i))
#define ISO_CELL(i) texelFetch(iso_cells_t, int(i)).xy
#ifdef ISO_WRITES_WEIGHTS
layout(std430, set = 0, binding = 3) writeonly buffer IsoWeighted { vec4 iso_weighted_out[]; };
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
    vec4 aniso;   // anisotropy: x: k_r, y: N_ε, z: centre blend λ, w: longest centre move (world units)
    vec4 aniso2;  // anisotropy: x: longest axis (units of h), z: neighbourhood radius (world units)
} pc;

/// Cubic spline without its constant (it cancels in φ); q = distance / support.
float iso_kernel(float q) {
    if (q <= 0.5) return 1.0 - 6.0 * q * q + 6.0 * q * q * q;
    if (q < 1.0) { float a = 1.0 - q; return 2.0 * a * a * a; }
    return 0.0;
}

#ifndef ISO_NO_WEIGHTS
/// Σ W(|x − x_j|) (weighted by 1/n_j when `weighted`) over the 3×3×3 cells around x; `dmin`: the distance
/// to the nearest point, capped at the cell size (no point in the 27 cells is at least that far). Cells are x
/// fastest and their points contiguous, so each of the 9 rows of 3 cells is one range of points (9 cell-table
/// pairs of reads instead of 27 lookups: the `iso` pass 198 → 127 ms on lavapipe, dam break 960×540).
float iso_sum(vec3 x, bool weighted, out float dmin) {
    ivec3 c = ivec3(floor((x - pc.origin.xyz) / pc.origin.w));
    ivec3 dims = ivec3(pc.dims.xyz);
    float s = 0.0;
    float d2min = pc.origin.w * pc.origin.w;
    float inv_h = 1.0 / pc.params.x;
    int x0 = max(c.x - 1, 0), x1 = min(c.x + 1, dims.x - 1);
    if (x0 > x1) {
        dmin = pc.origin.w;
        return 0.0;
    }
    for (int z = max(c.z - 1, 0); z <= min(c.z + 1, dims.z - 1); ++z) {
        for (int y = max(c.y - 1, 0); y <= min(c.y + 1, dims.y - 1); ++y) {
            {
                int row = dims.x * (y + dims.y * z);
                uint first = ISO_CELL(x0 + row).x;
                uvec2 last = ISO_CELL(x1 + row);
                for (uint i = first; i < last.x + last.y; ++i) {
                    vec4 pt = ISO_POINT(i);
                    vec3 v = pt.xyz - x;
                    float d2 = dot(v, v);
                    d2min = min(d2min, d2);
#ifdef ISO_ANISO_BINDING
                    // Weighted always (iso_aniso.comp only casts). The ellipsoid lies inside the ball of radius
                    // (longest axis) around its centre.
                    vec4 a0 = ISO_ANISO(3u * i);
                    vec3 u = x - a0.xyz;
                    float reach = pc.params.x * pc.aniso2.x;
                    if (dot(u, u) < reach * reach) {
                        vec4 a1 = ISO_ANISO(3u * i + 1u), a2 = ISO_ANISO(3u * i + 2u);
                        mat3 m = mat3(a1.x, a1.y, a1.z, a1.y, a1.w, a2.x, a1.z, a2.x, a2.y);
                        s += a0.w * iso_kernel(length(m * u) * inv_h) * pt.w;
                    }
#else
                    float w = iso_kernel(sqrt(d2) * inv_h);
                    s += weighted ? w * pt.w : w;
#endif
                }
            }
        }
    }
    dmin = sqrt(d2min);
    return s;
}
#endif
