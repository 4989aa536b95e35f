#version 460
//! mc_emit — the triangles (last stage of the `mc` pass): every cube with triangles writes them at its place
//! from the prefix sum, each vertex interpolated linearly on its edge, with the normal the CPU path gives it
//! (the negative field gradient by central differences of the corner values, interpolated along the edge), and
//! per triangle its cube's global corner and its edges, from which the host welds vertices on global edge keys
//! (watertight, the CPU path's vertex and triangle order). In: field, blocks, table, start.
//! Out: pos (3 per triangle), nrm (3 per triangle), tri (global cube corner xyz, w: table triangle | edges).
#include "mc_common.glsl"
layout(local_size_x = LOCAL_1D) in;
layout(std430, binding = 0) readonly buffer Field { float field[]; };
layout(std430, binding = 1) readonly buffer Blocks { ivec4 blocks[]; };
layout(std430, binding = 2) readonly buffer Table { uint table[]; };
layout(std430, binding = 3) readonly buffer Start { uint start[]; };
layout(std430, binding = 4) writeonly buffer Pos { vec4 pos[]; };
layout(std430, binding = 5) writeonly buffer Nrm { vec4 nrm[]; };
layout(std430, binding = 6) writeonly buffer Tri { ivec4 tri[]; };
#include "mc_cube.glsl"

float at(uint b, uvec3 l) { return field[b * MC_NC + corner_index(l)]; }

vec3 grad(uint b, uvec3 l) {
    return vec3(at(b, l + uvec3(1, 0, 0)) - at(b, l - uvec3(1, 0, 0)), at(b, l + uvec3(0, 1, 0)) - at(b, l - uvec3(0, 1, 0)),
                at(b, l + uvec3(0, 0, 1)) - at(b, l - uvec3(0, 0, 1)));
}

void main() {
    uint id = flat_group() * gl_WorkGroupSize.x + gl_LocalInvocationID.x;
    const uint per = MC_BLOCK * MC_BLOCK * MC_BLOCK;
    if (id >= uint(pc.ldims.w) * per) return;
    uvec3 l;
    uint mask = cube_mask(id, l);
    if (mask == 0u || mask == 255u) return;
    uint b = id / per;
    ivec3 c0 = blocks[b].xyz;
    uint n = table[MC_COUNTS + mask];
    uint o = start[id];
    for (uint t = 0u; t < n; ++t) {
        uint packed = t;
        for (uint v = 0u; v < 3u; ++v) {
            uint e = table[MC_EDGES + (mask * MC_MAX_TRIS + t) * 3u + v];
            packed |= e << (8u + 4u * v);
            uint ed = table[e];
            uint a = ed & 15u, bb = (ed >> 4) & 15u, axis = ed >> 8;
            uvec3 la = l + uvec3(a & 1u, (a >> 1) & 1u, (a >> 2) & 1u);
            uvec3 lb = l + uvec3(bb & 1u, (bb >> 1) & 1u, (bb >> 2) & 1u);
            float fa = at(b, la), fb = at(b, lb);
            float tt = clamp((pc.field.z - fa) / (fb - fa), 0.0, 1.0);
            vec3 p = pc.lat.xyz + vec3(c0 + ivec3(la)) * pc.lat.w;
            p[axis] += pc.lat.w * tt;
            vec3 g = -(grad(b, la) * (1.0 - tt) + grad(b, lb) * tt);
            float gl = length(g);
            pos[3u * (o + t) + v] = vec4(p, 0.0);
            nrm[3u * (o + t) + v] = vec4(gl > 0.0 && !isinf(gl) ? g / gl : vec3(0.0), 0.0);
        }
        tri[o + t] = ivec4(c0 + ivec3(l), int(packed));
    }
}
