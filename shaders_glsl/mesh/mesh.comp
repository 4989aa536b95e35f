#version 460
//! mesh — the fluid surface as the triangle mesh that marching cubes extracted from the SPH colour field
//! (src/field/extract/; Janisz thesis §2.2), ray-cast per pixel through its BVH (bvh.glsl) into the fluid depth,
//! replacing the splatted spheres (`--surface mesh`): the rest of the frame (smoothing, normals, reflections,
//! shading) is the same, so pictures compare like with like.
//! In: frame block, BVH nodes and triangles (world). Out: depth (r32f linear eye depth, +inf where no mesh).
#include "common.glsl"
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
layout(set = 0, binding = 1, r32f) uniform writeonly image2D depth_out;
layout(std430, set = 0, binding = 2) readonly buffer BvhNodes { vec4 nodes[]; };
layout(std430, set = 0, binding = 3) readonly buffer BvhTris { vec4 tris[]; };
layout(push_constant) uniform Push { uint node_count; } pc;
#include "bvh.glsl"

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(depth_out);
    if (any(greaterThanEqual(p, size))) return;
    // View ray with z = −1: the world hit parameter t is the linear eye depth itself.
    vec3 dv = pixel_dir(vec2(p), vec2(size), focal_for(float(size.y)));
    vec3 dw = mat3(frame.inv_view) * dv;
    float t;
    vec3 n;
    bool hit = hit_mesh(frame.eye.xyz, dw, INF, pc.node_count, t, n);
    imageStore(depth_out, p, vec4(hit && t >= frame.proj.w ? t : INF));
}
