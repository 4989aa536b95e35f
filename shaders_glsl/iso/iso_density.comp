#version 460
//! iso_density — first dispatch of the `iso` pass: per grid point j, 1/n_j with n_j = Σ_k W(|x_j − x_k|)
//! (the particle's SPH volume up to the rest mass; splashsurf's normalisation), and in the same neighbour loop
//! its neighbour count c_j = Σ_{k≠j} max(0, 1 − |x_j − x_k|²/h²) (splashsurf's feature weight, Löschner et al.
//! 2023: high in the bulk, low at the surface and in spray), which the smoothed field (iso_volume) deposits.
//! CPU reference: IsoGrid::inv_density and neighbour_weights in src/field/iso/mod.rs.
//! In: sorted points, cells. Out: the weighted points (xyz, 1/n_j), which the casts read; c_j.
#include "common.glsl"
#define ISO_WRITES_WEIGHTS
#include "iso_field.glsl"
layout(local_size_x = LOCAL_1D) in;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.dims.w) return;
    vec3 x = ISO_POINT(i).xyz;
    float h = pc.params.x, inv_h = 1.0 / h, inv_h2 = inv_h * inv_h;
    float n = 0.0, c = 0.0;
#define DENSITY_VISIT(k, pt, v, d2)                                                              \
    {                                                                                            \
        n += iso_kernel(sqrt(d2) * inv_h);                                                       \
        c += max(1.0 - (d2) * inv_h2, 0.0);                                                      \
    }
    ISO_FOR_POINTS(x, DENSITY_VISIT)
#undef DENSITY_VISIT
    iso_weighted_out[i] = vec4(x, 1.0 / n);
    iso_counts_out[i] = c - 1.0;  // itself
}
