#version 460
//! background — the scene behind the fluid, ray-cast analytically per pixel (compute).
//! Out: colour (rgba16f, linear) and LINEAR EYE DEPTH (r32f, +inf for sky) at full resolution.
//! A checkered ground plane with distance fog, the boxes of the frame block (Lambert + sun), an optional
//! triangle mesh from an OBJ file (walked through its BVH, src/mesh.rs; Möller–Trumbore 1997), shadows of
//! boxes and mesh on the ground, and the sky of common.glsl (procedural, or the cube map from six images).
//! Composite and thickness read the depth to hide fluid behind geometry.
#define SKY_BINDING 3
#include "common.glsl"
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
layout(set = 0, binding = 1, rgba16f) uniform writeonly image2D color_out;
layout(set = 0, binding = 2, r32f) uniform writeonly image2D depth_out;
layout(std430, set = 0, binding = 4) readonly buffer BvhNodes { vec4 nodes[]; };
layout(std430, set = 0, binding = 5) readonly buffer BvhTris { vec4 tris[]; };
layout(push_constant) uniform Push { uint node_count; } pc;

/// Möller–Trumbore, as mesh::ray_triangle.
float ray_triangle(vec3 o, vec3 d, vec3 a, vec3 b, vec3 c) {
    vec3 e1 = b - a, e2 = c - a;
    vec3 p = cross(d, e2);
    float det = dot(e1, p);
    if (abs(det) < 1e-12) return INF;
    float inv = 1.0 / det;
    vec3 s = o - a;
    float u = dot(s, p) * inv;
    if (u < 0.0 || u > 1.0) return INF;
    vec3 q = cross(s, e1);
    float v = dot(d, q) * inv;
    if (v < 0.0 || u + v > 1.0) return INF;
    float t = dot(e2, q) * inv;
    return t > 0.0 ? t : INF;
}

/// Nearest mesh hit t > 0 along o + t·d (below t_max) and its normal facing the ray; a stack walk of the BVH
/// (left child follows its parent; GpuBvh::intersect is the CPU mirror).
bool hit_mesh(vec3 o, vec3 d, float t_max, out float t_hit, out vec3 n_hit) {
    t_hit = t_max;
    n_hit = vec3(0, 1, 0);
    if (pc.node_count == 0u) return false;
    vec3 inv = 1.0 / d;
    uint stack[32];
    int sp = 0;
    stack[sp++] = 0u;
    bool hit = false;
    while (sp > 0) {
        uint n = stack[--sp];
        vec4 a = nodes[2u * n], b = nodes[2u * n + 1u];
        vec3 t0 = (a.xyz - o) * inv, t1 = (b.xyz - o) * inv;
        vec3 tl = min(t0, t1), th = max(t0, t1);
        float tn = max(max(max(tl.x, tl.y), tl.z), 0.0);
        float tf = min(min(th.x, th.y), th.z);
        if (tn > tf || tn >= t_hit) continue;
        uint count = floatBitsToUint(b.w);
        if (count > 0u) {
            uint first = floatBitsToUint(a.w);
            for (uint k = first; k < first + count; ++k) {
                vec3 v0 = tris[3u * k].xyz, v1 = tris[3u * k + 1u].xyz, v2 = tris[3u * k + 2u].xyz;
                float t = ray_triangle(o, d, v0, v1, v2);
                if (t < t_hit) {
                    t_hit = t;
                    n_hit = normalize(cross(v1 - v0, v2 - v0));
                    hit = true;
                }
            }
        } else if (sp < 31) {
            stack[sp++] = floatBitsToUint(a.w);
            stack[sp++] = n + 1u;
        }
    }
    if (dot(n_hit, d) > 0.0) n_hit = -n_hit;
    return hit;
}

/// Anything (box or mesh) between p and the sun.
bool in_shadow(vec3 p) {
    float ts; vec3 ns;
    return hit_boxes(p, frame.sun.xyz, ts, ns) || hit_mesh(p, frame.sun.xyz, INF, ts, ns);
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
    bool box = hit_boxes(o, dw, tb, nb);
    float tg = INF;
    if (frame.ground.z > 0.5 && dw.y < 0.0) tg = (frame.ground.x - o.y) / dw.y;
    if (tg <= 0.0) tg = INF;
    float ambient = frame.fluid_color.w;
    float diffuse_sun = frame.sun.w;
    float tm; vec3 nm;
    bool mesh = hit_mesh(o, dw, min(tg, box ? tb : INF), tm, nm);
    if (mesh) {
        t = tm;
        vec3 hp = o + t * dw;
        float lit = max(dot(nm, frame.sun.xyz), 0.0);
        if (lit > 0.0 && in_shadow(hp + nm * 1e-4 * max(t, 1.0))) lit *= 0.35;
        c = vec3(0.70, 0.68, 0.62) * (ambient + diffuse_sun * lit);
    } else if (box && tb < tg) {
        t = tb;
        vec3 base = vec3(0.78, 0.42, 0.30);
        vec3 hp = o + t * dw;
        // Faint stripes so reflections and refraction of the boxes read as texture.
        float stripe = 0.85 + 0.15 * step(0.5, fract(hp.y / max(frame.ground.y * 0.5, 1e-6)));
        c = base * stripe * (ambient + diffuse_sun * max(dot(nb, frame.sun.xyz), 0.0));
    } else if (tg < INF) {
        t = tg;
        vec3 hp = o + t * dw;
        vec2 cell = floor(hp.xz / frame.ground.y);
        float checker = mod(cell.x + cell.y, 2.0);
        vec3 base = mix(vec3(0.62, 0.60, 0.56), vec3(0.30, 0.32, 0.34), checker);
        // Shadow of the boxes on the ground.
        float shadow = in_shadow(hp + vec3(0, 1e-4, 0)) ? 0.35 : 1.0;
        c = base * (ambient + diffuse_sun * shadow * max(frame.sun.y, 0.0));
        float fog = 1.0 - exp(-t / max(frame.ground.w, 1e-6));
        c = mix(c, sky(vec3(dw.x, 0.0, dw.z)), clamp(fog, 0.0, 1.0));
    }
    imageStore(color_out, p, vec4(c, 1.0));
    imageStore(depth_out, p, vec4(t));
}
