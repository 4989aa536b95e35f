#version 460
//! mc_field — the field at every corner of every occupied block (first stage of the `mc` pass, GPU marching
//! cubes). One work group per block; each corner GATHERS the particles of the 3×3×3 neighbour-grid cells around
//! it (cells ≥ the kernel support), in ascending cell order and sorted order within a cell — the same terms in
//! the same order as the CPU's scatter (src/field/extract/blocks.rs), so the values agree to rounding.
//! Field: the SPH colour field Σ W(|x − x_j| / h) / n_j (cubic spline, splashsurf's), or the thesis' metaball
//! field Σ f(|x − x_j| / R_c) (Janisz §2.2). In: points (sorted), cells, weights 1/n_j, blocks (c0).
//! Out: field[block × MC_NC + corner].
//! MC_LIVE: the points are the renderer's grid's weighted points (xyz, 1/n_j: iso_density's), binding 2 the
//! block count (mc_common.glsl).
#define MC_LIVE_BINDING 2
#include "mc_common.glsl"
layout(local_size_x = 128) in;
layout(std430, binding = 0) readonly buffer Points { vec4 pts[]; };
layout(std430, binding = 1) readonly buffer Cells { uvec2 cells[]; };
#ifdef MC_LIVE
#define WEIGHT(j) pts[j].w
#else
layout(std430, binding = 2) readonly buffer Weights { float wts[]; };
#define WEIGHT(j) wts[j]
#endif
layout(std430, binding = 3) readonly buffer Blocks { ivec4 blocks[]; };
layout(std430, binding = 4) writeonly buffer Field { float field[]; };

float kernel(float q) {
    if (pc.gdims.w == 1u) {
        float s = 0.5 * q * q - 0.5;
        return q < 1.0 ? s * s : 0.0;
    }
    float a = 1.0 - q;
    if (q <= 0.5) return 1.0 - 6.0 * q * q + 6.0 * q * q * q;
    if (q < 1.0) return 2.0 * a * a * a;
    return 0.0;
}

void main() {
    uint b = flat_group();
    if (b >= MC_BLOCKS) return;
    ivec3 c0 = blocks[b].xyz;
    ivec3 gd = ivec3(pc.gdims.xyz);
    float s2 = pc.field.x * pc.field.x;
    for (uint c = gl_LocalInvocationID.x; c < MC_NC; c += gl_WorkGroupSize.x) {
        uvec3 l = uvec3(c % MC_N, (c / MC_N) % MC_N, c / (MC_N * MC_N));
        vec3 x = pc.lat.xyz + vec3(c0 + ivec3(l)) * pc.lat.w;
        ivec3 cc = ivec3(floor((x - pc.grid.xyz) / pc.grid.w));
        float v = 0.0;
        // The 9 rows of 3 cells, each one contiguous range of points (cells are x fastest).
        int x0 = max(cc.x - 1, 0), x1 = min(cc.x + 1, gd.x - 1);
        for (int z = max(cc.z - 1, 0); z <= min(cc.z + 1, gd.z - 1); ++z)
        for (int y = max(cc.y - 1, 0); y <= min(cc.y + 1, gd.y - 1) && x0 <= x1; ++y) {
            int row = gd.x * (y + gd.y * z);
            uint first = cells[x0 + row].x;
            uvec2 last = cells[x1 + row];
            for (uint j = first; j < last.x + last.y; ++j) {
                vec3 p = pts[j].xyz;
                float dy = x.y - p.y, dz = x.z - p.z, dx = x.x - p.x;
                float d2 = dy * dy + dz * dz;
                if (d2 >= s2) continue;
                float q = sqrt(dx * dx + d2) * pc.field.y;
                v += kernel(q) * (pc.gdims.w == 1u ? 1.0 : WEIGHT(j));
            }
        }
        field[b * MC_NC + c] = v;
    }
}
