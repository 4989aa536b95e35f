#version 460
//! background — the scene behind the fluid, ray-cast analytically per pixel (compute).
//! Out: colour (rgba16f, linear) and LINEAR EYE DEPTH (r32f, +inf for sky) at full resolution.
//! A checkered ground plane with distance fog, the boxes of the frame block (Lambert + sun), an optional
//! triangle mesh from an OBJ file (walked through its BVH, src/scene/geometry.rs; Möller–Trumbore 1997), shadows of
//! boxes and mesh on the ground, and the sky of common.glsl (procedural, or the cube map from six images).
//! Composite and thickness read the depth to hide fluid behind geometry.
#define SKY_BINDING 3
#include "common.glsl"
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
layout(set = 0, binding = 1, rgba16f) uniform writeonly image2D color_out;
layout(set = 0, binding = 2, r32f) uniform writeonly image2D depth_out;
// BACKGROUND_MESH (the variant run while a mesh is set): the mesh's BVH. Without one the BVH walk is not compiled
// at all: lavapipe ran it, masked, for every pixel's three rays even with no node to visit.
#ifdef BACKGROUND_MESH
layout(std430, set = 0, binding = 4) readonly buffer BvhNodes { vec4 nodes[]; };
layout(std430, set = 0, binding = 5) readonly buffer BvhTris { vec4 tris[]; };
layout(push_constant) uniform Push { uint node_count; } pc;

#include "bvh.glsl"
#endif

/// Anything (box or mesh) between p and the sun.
bool in_shadow(vec3 p) {
    float ts; vec3 ns;
#ifdef BACKGROUND_MESH
    return hit_scenery(p, frame.sun.xyz, ts, ns) || hit_mesh(p, frame.sun.xyz, INF, pc.node_count, ts, ns);
#else
    return hit_scenery(p, frame.sun.xyz, ts, ns);
#endif
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(color_out);
    if (any(greaterThanEqual(p, size))) return;
    vec3 dv = pixel_dir(vec2(p), vec2(size), focal_for(float(size.y)));
    vec3 dw = mat3(frame.inv_view) * dv; // world direction; t along it is the linear eye depth
    vec3 o = frame.eye.xyz;
    float t = INF;
    vec3 c = sky(dw);
    float tb; vec3 nb;
    bool box = hit_scenery(o, dw, tb, nb);
    float tg = INF;
    if (frame.ground.z > 0.5 && dw.y < 0.0) tg = (frame.ground.x - o.y) / dw.y;
    if (tg <= 0.0) tg = INF;
    float ambient = frame.fluid_color.w;
    float diffuse_sun = frame.sun.w;
    float tm = INF; vec3 nm = vec3(0, 1, 0);
    bool mesh = false;
#ifdef BACKGROUND_MESH
    mesh = hit_mesh(o, dw, min(tg, box ? tb : INF), pc.node_count, tm, nm);
#endif
    // One shadow ray, from the mesh where the sun lights it or from the ground (a ray in each branch was run, masked,
    // for every pixel on lavapipe).
    bool ground = !mesh && !(box && tb < tg) && tg < INF;
    float lit_mesh = max(dot(nm, frame.sun.xyz), 0.0);
    vec3 hp_mesh = o + tm * dw, hp_ground = o + tg * dw;
    vec3 from = mesh ? hp_mesh + nm * 1e-4 * max(tm, 1.0) : hp_ground + vec3(0, 1e-4, 0);
    bool shadowed = ((mesh && lit_mesh > 0.0) || ground) && in_shadow(from);
    if (mesh) {
        t = tm;
        c = vec3(0.70, 0.68, 0.62) * (ambient + diffuse_sun * (shadowed ? lit_mesh * 0.35 : lit_mesh));
    } else if (box && tb < tg) {
        t = tb;
        vec3 base = vec3(0.78, 0.42, 0.30);
        vec3 hp = o + t * dw;
        // Faint stripes so reflections and refraction of the boxes read as texture.
        float stripe = 0.85 + 0.15 * step(0.5, fract(hp.y / max(frame.ground.y * 0.5, 1e-6)));
        c = base * stripe * (ambient + diffuse_sun * max(dot(nb, frame.sun.xyz), 0.0));
    } else if (ground) {
        t = tg;
        vec2 cell = floor(hp_ground.xz / frame.ground.y);
        float checker = mod(cell.x + cell.y, 2.0);
        vec3 base = mix(vec3(0.62, 0.60, 0.56), vec3(0.30, 0.32, 0.34), checker);
        // Shadow of the boxes (and mesh) on the ground.
        float shadow = shadowed ? 0.35 : 1.0;
        c = base * (ambient + diffuse_sun * shadow * max(frame.sun.y, 0.0));
        float fog = 1.0 - exp(-t / max(frame.ground.w, 1e-6));
        c = mix(c, sky(vec3(dw.x, 0.0, dw.z)), clamp(fog, 0.0, 1.0));
    }
    imageStore(color_out, p, vec4(c, 1.0));
    imageStore(depth_out, p, vec4(t));
}
