#version 460
//! filter_bilateral — depth smoothing of the `filter` pass: bilateral filter (Moritz eq. 3.9; Janisz eqs. 2.1–2.3):
//! w = exp(−Δi²/(2σ_d²) − Δz²/(2σ_r²)), normalised; background samples are skipped and background stays
//! background. The kernel is constant in WORLD space: radius_px = ρ·F/d, clamped to max_px.
//! Modes: separable (one axis per dispatch, `dir`), exact 2D (`dir` = 0), Gaussian (σ_r = 0: no range term).
//! In: depth (r32f). Out: smoothed depth (r32f).
#include "common.glsl"
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
layout(set = 0, binding = 1, r32f) uniform readonly image2D src;
layout(set = 0, binding = 2, r32f) uniform writeonly image2D dst;
layout(push_constant) uniform Push {
    ivec2 dir;          // (1,0) or (0,1): separable axis; (0,0): exact 2D
    float world_radius; // ρ, world units
    float sigma_range;  // σ_r, world units; 0 disables the range weight (Gaussian)
    int max_px;         // kernel radius cap in pixels
} pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(src);
    if (any(greaterThanEqual(p, size))) return;
    float d = imageLoad(src, p).x;
    if (!is_fluid(d)) {
        imageStore(dst, p, vec4(d));
        return;
    }
    float F = focal_for(float(size.y));
    float radius_px = clamp(pc.world_radius * F / d, 1.0, float(pc.max_px));
    int R = int(ceil(radius_px));
    float sigma_d = max(radius_px * 0.5, 0.5);
    float kd = 1.0 / (2.0 * sigma_d * sigma_d);
    float kr = pc.sigma_range > 0.0 ? 1.0 / (2.0 * pc.sigma_range * pc.sigma_range) : 0.0;
    float sum = d, wsum = 1.0;
    if (pc.dir != ivec2(0)) {
        for (int i = -R; i <= R; ++i) {
            ivec2 q = p + i * pc.dir;
            if (i == 0 || any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
            float dq = imageLoad(src, q).x;
            if (!is_fluid(dq)) continue;
            float dz = dq - d;
            float w = exp(-float(i * i) * kd - dz * dz * kr);
            sum += w * dq;
            wsum += w;
        }
    } else {
        for (int j = -R; j <= R; ++j) {
            for (int i = -R; i <= R; ++i) {
                ivec2 q = p + ivec2(i, j);
                if ((i == 0 && j == 0) || any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
                float dq = imageLoad(src, q).x;
                if (!is_fluid(dq)) continue;
                float dz = dq - d;
                float w = exp(-float(i * i + j * j) * kd - dz * dz * kr);
                sum += w * dq;
                wsum += w;
            }
        }
    }
    imageStore(dst, p, vec4(sum / wsum));
}
