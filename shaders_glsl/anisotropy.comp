#version 460
//! anisotropy — the anisotropic kernels of Yu & Turk 2013 ("Reconstructing surfaces of particle-based fluids
//! using anisotropic kernels", §4), one thread per sorted grid point: the weighted mean and covariance of the
//! neighbours within the kernel support h (weights 1 − (d/h)³, the point included), the covariance's
//! eigen-decomposition (cyclic Jacobi, the same steps as `sym_eigen` in src/field/iso/mod.rs; the neighbourhood's radius is
//! pc.aniso2.z: h, or up to 2 h as in the paper, N_ε still counts within h), the small eigenvalues
//! raised to σ_max / k_r, and the kernel matrix M = R diag(1 / a_k) Rᵀ with semi-axes a_k h ∝ σ̃_k, of the
//! sphere's volume unless the longest would exceed pc.aniso2.x h (the field multiplies by det M so the
//! kernel's integral is unchanged). Points with fewer than N_ε neighbours keep the
//! sphere. The centre moves by λ towards the weighted mean (eq. 6), at most pc.aniso.w.
//! CPU reference: IsoGrid::anisotropy / Aniso::from_covariance in src/field/iso/mod.rs.
//! In: sorted points, cells. Out: aniso (three vec4 per point: centre + det M, m00 m01 m02 m11, m12 m22).
#include "common.glsl"
#define ISO_NO_WEIGHTS
#include "iso/iso_field.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, set = 0, binding = 3) writeonly buffer Aniso { vec4 aniso[]; };


/// Eigenvalues (the diagonal of `a` on return) and eigenvectors (the columns of v, v[row][col]).
void sym_eigen(inout float a[3][3], out float v[3][3]) {
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) v[r][c] = r == c ? 1.0 : 0.0;
    for (int sweep = 0; sweep < JACOBI_SWEEPS; ++sweep) {
        for (int k = 0; k < 3; ++k) {
            int p = k == 2 ? 1 : 0;
            int q = k == 0 ? 1 : 2;
            float apq = a[p][q];
            if (abs(apq) <= 1e-30) continue;
            float theta = (a[q][q] - a[p][p]) / (2.0 * apq);
            float sgn = theta >= 0.0 ? 1.0 : -1.0;
            float t = sgn / (abs(theta) + sqrt(theta * theta + 1.0));
            float c = 1.0 / sqrt(t * t + 1.0);
            float s = t * c;
            for (int r = 0; r < 3; ++r) {
                float kp = a[r][p], kq = a[r][q];
                a[r][p] = c * kp - s * kq;
                a[r][q] = s * kp + c * kq;
            }
            for (int r = 0; r < 3; ++r) {
                float kp = v[r][p], kq = v[r][q];
                v[r][p] = c * kp - s * kq;
                v[r][q] = s * kp + c * kq;
            }
            for (int r = 0; r < 3; ++r) {
                float pk = a[p][r], qk = a[q][r];
                a[p][r] = c * pk - s * qk;
                a[q][r] = s * pk + c * qk;
            }
        }
    }
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.dims.w) return;
    vec3 x = ISO_POINT(i).xyz;
    float h = pc.params.x;
    ivec3 dims = ivec3(pc.dims.xyz);
    // The point's own cell (clamped into the grid as the grid's sort does).
    ivec3 cc = clamp(ivec3(floor((x - pc.origin.xyz) / pc.origin.w)), ivec3(0), dims - 1);
    float sw = 0.0;
    vec3 sv = vec3(0.0);
    float svv[3][3];
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) svv[r][c] = 0.0;
    uint n = 0u;
    // The neighbourhood: radius R = pc.aniso2.z (h, or up to 2 h as Yu & Turk), over the rows of cells within
    // K = ⌈R / cell⌉ of the point's cell, each row one contiguous range of points (as iso_sum).
    float R = pc.aniso2.z;
    int K = int(ceil(R / pc.origin.w - 1e-5));
    int x0 = max(cc.x - K, 0), x1 = min(cc.x + K, dims.x - 1);
    for (int z = max(cc.z - K, 0); z <= min(cc.z + K, dims.z - 1); ++z) {
        for (int y = max(cc.y - K, 0); y <= min(cc.y + K, dims.y - 1); ++y) {
            {
                int row = dims.x * (y + dims.y * z);
                uint first = ISO_CELL(x0 + row).x;
                uvec2 last = ISO_CELL(x1 + row);
                for (uint j = first; j < last.x + last.y; ++j) {
                    vec3 v = ISO_POINT(j).xyz - x;
                    float d = length(v);
                    if (d >= R) continue;
                    float qq = d / R;
                    float w = 1.0 - qq * qq * qq;
                    sw += w;
                    sv += w * v;
                    for (int r = 0; r < 3; ++r)
                        for (int c = 0; c < 3; ++c) svv[r][c] += w * v[r] * v[c];
                    if (j != i && d < h) n += 1u;
                }
            }
        }
    }
    vec3 mean = sv / sw;
    float a[3][3];
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) a[r][c] = svv[r][c] / sw - mean[r] * mean[c];
    vec3 shift = mean * pc.aniso.z;
    float len = length(shift);
    if (len > pc.aniso.w) shift *= pc.aniso.w / len;
    vec3 centre = x + shift;
    float v[3][3];
    sym_eigen(a, v);
    float smax = max(a[0][0], max(a[1][1], a[2][2]));
    float m[3][3];
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) m[r][c] = r == c ? 1.0 : 0.0;
    float det = 1.0;
    if (float(n) >= pc.aniso.y && smax > 1e-12 * h * h) {
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) m[r][c] = 0.0;
        vec3 sv3 = max(vec3(a[0][0], a[1][1], a[2][2]), vec3(smax / pc.aniso.x)) / smax;
        float g = pow(sv3.x * sv3.y * sv3.z, 1.0 / 3.0);
        float scale = min(1.0 / g, max(pc.aniso2.x, 1.0)) * g;
        for (int k = 0; k < 3; ++k) {
            float s = sv3[k] / g * scale;
            det /= s;
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 3; ++c) m[r][c] += v[r][k] * v[c][k] / s;
        }
    }
    aniso[3u * i] = vec4(centre, det);
    aniso[3u * i + 1u] = vec4(m[0][0], m[0][1], m[0][2], m[1][1]);
    aniso[3u * i + 2u] = vec4(m[1][2], m[2][2], 0.0, 0.0);
}
