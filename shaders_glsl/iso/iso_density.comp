#version 460
//! iso_density — first dispatches of the `iso` pass, per grid point j. Plain: 1/n_j with n_j = Σ_k W(|x_j −
//! x_k|) (the particle's SPH volume up to the rest mass; splashsurf's normalisation), and in the same neighbour
//! loop its neighbour count c_j = Σ_{k≠j} max(0, 1 − |x_j − x_k|²/h²) (splashsurf's feature weight, Löschner et
//! al. 2023: high in the bulk, low at the surface and in spray), which the smoothed field (iso_volume)
//! deposits, and two sums for its lattice order, over the neighbours within h at distances t in particle
//! spacings (2 r, the frame's radius): g_j, those between a lattice's first two shells (a tent over
//! LATTICE_GAP_AT ± LATTICE_GAP_HALF), and m_j, the near ones (t < LATTICE_NEAR_FROM … TO).
//! ISO_DENSITY_ORDER: the order o_j from those sums pooled over j's neighbourhood (weights 1 − d²/h², itself
//! 1): 1 − smoothstep(LATTICE_SHARE_FROM, LATTICE_SHARE_TO, Σ g / Σ m), times smoothstep(LATTICE_FEW,
//! LATTICE_MANY, m_j) (a particle with few near neighbours is spray, not a lattice). One particle's gap holds
//! about one liquid neighbour at a surface, so zero is common by chance; pooled over some 30 it is not, while
//! a lattice's stays 0. The order widens the point's deposit (`[iso] lattice_smoothing`): a lattice's
//! surface crosses its layers in terraces wider than a liquid's bumps.
//! CPU reference: IsoGrid::inv_density (src/field/iso/mod.rs) and volume_weights (src/field/volume.rs).
//! Plain in: the frame (radius), sorted points, cells. Out: the weighted points (xyz, 1/n_j), which the casts
//! read; (c_j, 0) (4); (g_j, m_j) (5). ORDER in: the frame, sorted points, cells, (g, m) (3); out: .y of (c_j,
//! o_j) (4).
#include "common.glsl"
#if defined(ISO_DENSITY_ORDER)
#include "iso_field.glsl"
layout(set = 0, binding = 3) uniform samplerBuffer lattice_t;  // RG32F: (g_k, m_k)
layout(std430, set = 0, binding = 4) buffer IsoCounts { vec2 iso_counts[]; };
#else
#define ISO_WRITES_WEIGHTS
#include "iso_field.glsl"
layout(std430, set = 0, binding = 5) writeonly buffer IsoLattice { vec2 iso_lattice_out[]; };
#endif
layout(local_size_x = LOCAL_1D) in;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.dims.w) return;
    vec3 x = ISO_POINT(i).xyz;
    float h = pc.params.x, inv_h = 1.0 / h, inv_h2 = inv_h * inv_h;
#if defined(ISO_DENSITY_ORDER)
    float gap = 0.0, near = 0.0;
#define ORDER_VISIT(k, pt, v, d2)                                                                \
    if (d2 < h * h) {                                                                            \
        vec2 gm_ = texelFetch(lattice_t, int(k)).xy;                                             \
        float w_ = 1.0 - (d2) * inv_h2;                                                          \
        gap += w_ * gm_.x;                                                                       \
        near += w_ * gm_.y;                                                                      \
    }
    ISO_FOR_POINTS(x, ORDER_VISIT)
#undef ORDER_VISIT
    float own = texelFetch(lattice_t, int(i)).y;
    iso_counts[i].y = (1.0 - smoothstep(LATTICE_SHARE_FROM, LATTICE_SHARE_TO, gap / max(near, 1.0)))
                      * smoothstep(LATTICE_FEW, LATTICE_MANY, own);
#else
    float inv_a = 0.5 / frame.fluid.x;
    float n = 0.0, c = 0.0, gap = 0.0, near = 0.0;
#define DENSITY_VISIT(k, pt, v, d2)                                                              \
    {                                                                                            \
        float d_ = sqrt(d2);                                                                     \
        n += iso_kernel(d_ * inv_h);                                                             \
        if (d2 < h * h) {                                                                        \
            c += 1.0 - (d2) * inv_h2;                                                            \
            float t_ = d_ * inv_a;                                                               \
            gap += max(1.0 - abs(t_ - LATTICE_GAP_AT) / LATTICE_GAP_HALF, 0.0);                  \
            near += 1.0 - smoothstep(LATTICE_NEAR_FROM, LATTICE_NEAR_TO, t_);                     \
        }                                                                                        \
    }
    ISO_FOR_POINTS(x, DENSITY_VISIT)
#undef DENSITY_VISIT
    iso_weighted_out[i] = vec4(x, 1.0 / n);
    // Less itself (d = 0: c's term 1, the near count's 1, no gap).
    iso_counts_out[i] = vec2(c - 1.0, 0.0);
    iso_lattice_out[i] = vec2(gap, near - 1.0);
#endif
}
