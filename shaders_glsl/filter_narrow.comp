#version 460
//! filter_narrow — narrow-range filter of the `filter` pass (Truong & Yuksel, I3D 2018).
//! A Gaussian (σ = radius/2, radius = ρ·F/d px) whose samples are judged against an accepted depth range
//! [lo, hi] that starts at d ± threshold: a sample in FRONT of lo (another surface nearer the camera) is
//! dropped together with its mirror sample; a sample BEHIND hi (a surface further back, or background) is
//! clamped to d + μ; an accepted sample widens the range to its own depth ± threshold.
//! Separable dispatches (`dir`), then one 2D dispatch over a small window (`dir` = 0, radius ≤ 2D radius).
//! In: depth (r32f). Out: filtered depth (r32f). Background stays background.
#include "common.glsl"
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
layout(set = 0, binding = 1, r32f) uniform readonly image2D src;
layout(set = 0, binding = 2, r32f) uniform writeonly image2D dst;
layout(push_constant) uniform Push {
    ivec2 dir;          // separable axis, or (0,0) for the 2D pass
    float world_radius; // ρ (world)
    float threshold;    // accepted range half-width (world), ≈ 10 r
    float mu;           // clamp offset behind the centre (world), ≈ r
    int max_px;         // kernel radius cap (px)
    int radius_2d;      // window radius of the 2D pass (px)
    int skip_background;// 1: background samples are dropped (with their mirror) instead of clamped
} pc;

ivec2 g_size;

float sample_depth(ivec2 q) {
    if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, g_size))) return INF;
    return imageLoad(src, q).x;
}

/// Judge one sample against the range; returns false when it must be dropped (with its mirror).
bool judge(inout float z, inout float lo, inout float hi, float d) {
    if (z < lo || (pc.skip_background != 0 && !is_fluid(z))) return false;
    if (z > hi) {
        z = d + pc.mu;
    } else {
        lo = min(lo, z - pc.threshold);
        hi = max(hi, z + pc.threshold);
    }
    return true;
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    g_size = imageSize(src);
    if (any(greaterThanEqual(p, g_size))) return;
    float d = imageLoad(src, p).x;
    if (!is_fluid(d)) {
        imageStore(dst, p, vec4(d));
        return;
    }
    float F = focal_for(float(g_size.y));
    float radius_px = clamp(pc.world_radius * F / d, 1.0, float(pc.max_px));
    float sigma = max(radius_px * 0.5, 0.5);
    float k = 1.0 / (2.0 * sigma * sigma);
    float sum = d, wsum = 1.0;
    float lo = d - pc.threshold, hi = d + pc.threshold;
    if (pc.dir != ivec2(0)) {
        int R = int(ceil(radius_px));
        for (int i = 1; i <= R; ++i) {
            float za = sample_depth(p - i * pc.dir);
            float zb = sample_depth(p + i * pc.dir);
            bool ka = judge(za, lo, hi, d);
            bool kb = judge(zb, lo, hi, d);
            if (ka && kb) {
                float w = exp(-float(i * i) * k);
                sum += w * (za + zb);
                wsum += 2.0 * w;
            }
        }
    } else {
        int R = min(pc.radius_2d, int(ceil(radius_px)));
        // Visit mirror pairs (q, −q) over the half window, ring by ring outwards.
        for (int r = 1; r <= R; ++r) {
            for (int j = -r; j <= r; ++j) {
                for (int i = -r; i <= r; ++i) {
                    if (max(abs(i), abs(j)) != r) continue;
                    if (j < 0 || (j == 0 && i < 0)) continue; // the mirror covers the other half
                    float za = sample_depth(p + ivec2(i, j));
                    float zb = sample_depth(p - ivec2(i, j));
                    bool ka = judge(za, lo, hi, d);
                    bool kb = judge(zb, lo, hi, d);
                    if (ka && kb) {
                        float w = exp(-float(i * i + j * j) * k);
                        sum += w * (za + zb);
                        wsum += 2.0 * w;
                    }
                }
            }
        }
    }
    imageStore(dst, p, vec4(sum / wsum));
}
