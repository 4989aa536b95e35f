//! curvature.glsl — one explicit curvature-flow step at one pixel (van der Laan et al. 2009; Moritz eq. 3.10),
//! shared by filter_curvature.comp (tiled, several iterations per dispatch) and filter_curvature1.comp (one
//! iteration per dispatch, no shared memory). n0…n8: the 3×3 neighbourhood (row-major, centre z), with
//! background / far neighbours already replaced by z. Positive depth: d ← d − Δt·H.
float curvature_step(float z, float n0, float n1, float n2, float n3, float n5, float n6, float n7, float n8,
                     float F, float dt_in, float kappa) {
    float C = 1.0 / F;
    float zx = 0.5 * (n5 - n3);
    float zy = 0.5 * (n7 - n1);
    float zxx = n5 - 2.0 * z + n3;
    float zyy = n7 - 2.0 * z + n1;
    float zxy = 0.25 * (n8 - n6 - n2 + n0);
    float zk = z + kappa;
    float C2 = C * C;
    float D = C2 * zx * zx + C2 * zy * zy + C2 * C2 * zk * zk;
    float Dx = 2.0 * C2 * zx * zxx + 2.0 * C2 * zy * zxy + 2.0 * C2 * C2 * zk * zx;
    float Dy = 2.0 * C2 * zx * zxy + 2.0 * C2 * zy * zyy + 2.0 * C2 * C2 * zk * zy;
    float H = (C * (0.5 * zx * Dx - zxx * D) + C * (0.5 * zy * Dy - zyy * D)) / (2.0 * pow(D, 1.5));
    // Stability of the explicit step: for small slopes the update is λ·Laplacian with λ = Δt·F/(2(z+κ));
    // keep λ ≤ 0.2.
    // dt_in ≤ 0 asks for that largest stable step.
    float dt_stable = 0.2 * 2.0 * zk / F;
    float dt = dt_in > 0.0 ? min(dt_in, dt_stable) : dt_stable;
    return z - dt * H;
}
