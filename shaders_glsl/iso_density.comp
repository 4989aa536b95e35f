#version 460
//! iso_density — first dispatch of the `iso` pass: per grid point j, 1/n_j with n_j = Σ_k W(|x_j − x_k|)
//! (the particle's SPH volume up to the rest mass; splashsurf's normalisation). CPU reference:
//! IsoGrid::inv_density in src/surface/iso/field.rs.
//! In: sorted points, cells. Out: the weighted points (xyz, 1/n_j), which the casts read.
#include "common.glsl"
#define ISO_WRITES_WEIGHTS
#include "iso_field.glsl"
layout(local_size_x = LOCAL_1D) in;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.dims.w) return;
    float dmin;
    vec3 x = ISO_POINT(i).xyz;
    iso_weighted_out[i] = vec4(x, 1.0 / iso_sum(x, false, dmin));
}
