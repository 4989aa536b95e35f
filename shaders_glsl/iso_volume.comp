#version 460
//! iso_volume — builds the sums of the smoothed iso field (`[iso] smoothing` > 0) once per set of particles,
//! after iso_density: per sorted point j, its neighbour count c_j = Σ_{k≠j} max(0, 1 − |x_j − x_k|²/h²)
//! (splashsurf's feature weight, Löschner et al.), then a scatter over the lattice voxels v within its support:
//!     acc[2v]     += W(|v − x_j|/h) / n_j          (the colour field φ at the voxel)
//!     acc[2v + 1] += W(|v − x_j|/h) c_j / n_j      (so c̄ = acc[2v+1] / acc[2v] is c interpolated Shepard-style)
//! in fixed point (ISO_VOLUME_FIX_BITS) with integer atomics: the same sums in any order, on any device.
//! iso_blur then blurs φ where c̄ says the water is bulk. The field smoothing follows the mesh smoothing that
//! splashsurf weights by c_j (Löschner et al. 2023), moved from the mesh to the field so a ray cast can draw it.
//! CPU reference: IsoGrid::volume_sums in src/surface/iso/field.rs.
//! Each point also marks the bricks (ISO_VOLUME_BRICK³ voxels) its support's box touches, so iso_blur can skip
//! the rest.
//! In: the weighted points (xyz, 1/n_j), cells. Out: acc (binding 3), the bricks' occupied flags (binding 4,
//! the first half; both zeroed by the host before).
#include "common.glsl"
#include "iso_field.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, set = 0, binding = 3) buffer IsoVolumeAcc { uint acc[]; };
layout(std430, set = 0, binding = 4) writeonly buffer IsoVolumeBricks { uint bricks[]; };

void main() {
    uint j = gl_GlobalInvocationID.x;
    if (j >= pc.dims.w) return;
    vec4 pj = ISO_POINT(j);
    float h = pc.params.x;
    float inv_h2 = 1.0 / (h * h);
    float c = 0.0;
#define C_VISIT(i, pt, v, d2) { c += max(1.0 - (d2) * inv_h2, 0.0); }
    vec3 x = pj.xyz;  // (the macro's own `.x` swizzles take a plain name only)
    ISO_FOR_POINTS(x, C_VISIT)
#undef C_VISIT
    c -= 1.0;  // itself
    float fix = float(1u << ISO_VOLUME_FIX_BITS);
    float s = pc.aniso.w;
    ivec3 dims = ivec3(pc.aniso2.yzw);
    vec3 u = (x - pc.aniso.xyz) / s;
    float rv = h / s;
    ivec3 lo = max(ivec3(ceil(u - rv)), ivec3(0));
    ivec3 hi = min(ivec3(floor(u + rv)), dims - 1);
    float inv_h = 1.0 / h;
    ivec3 bd = (dims + int(ISO_VOLUME_BRICK) - 1) / int(ISO_VOLUME_BRICK);
    ivec3 b0 = lo / int(ISO_VOLUME_BRICK), b1 = hi / int(ISO_VOLUME_BRICK);
    for (int bz = b0.z; bz <= b1.z; ++bz)
        for (int by = b0.y; by <= b1.y; ++by)
            for (int bx = b0.x; bx <= b1.x; ++bx) bricks[bx + bd.x * (by + bd.y * bz)] = 1u;
    for (int z = lo.z; z <= hi.z; ++z) {
        for (int y = lo.y; y <= hi.y; ++y) {
            int row = dims.x * (y + dims.y * z);
            for (int i = lo.x; i <= hi.x; ++i) {
                float q = length((vec3(i, y, z) - u) * s) * inv_h;
                if (q < 1.0) {
                    float w = iso_kernel(q) * pj.w;
                    uint v = 2u * uint(row + i);
                    atomicAdd(acc[v], uint(w * fix + 0.5));
                    atomicAdd(acc[v + 1u], uint(w * c * fix + 0.5));
                }
            }
        }
    }
}
