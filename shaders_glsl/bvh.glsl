//! bvh.glsl — a ray against a triangle mesh through its BVH (src/scene/geometry.rs GpuBvh; Möller–Trumbore 1997), shared
//! by `background` (an OBJ mesh in the scene) and `mesh` (the fluid's extracted iso-surface). The including
//! shader declares the buffers `nodes` (two vec4 per node) and `tris` (three vec4 per triangle).

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
bool hit_mesh(vec3 o, vec3 d, float t_max, uint node_count, out float t_hit, out vec3 n_hit) {
    t_hit = t_max;
    n_hit = vec3(0, 1, 0);
    if (node_count == 0u) return false;
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

