#version 460
//! mesh_raster (vertex) — the live mesh surface (`[mesh] extraction = "gpu"`, src/surface/mesh/live.rs): the
//! triangles the `mc` pass extracted on the device this frame, drawn straight from its buffers (no vertex input,
//! no read-back; the draw's vertex count is the device's, an indirect draw). Vertex k of the draw is corner
//! k % 3 of triangle k / 3. Projected as common.glsl maps view space to pixels, in reversed Z (near / d, so the
//! GREATER test keeps the nearest): the fragment shader writes no depth, so the depth test runs before it (early
//! depth: a hidden fragment costs no shading). In: frame, vertex positions (3 floats each), triangles (3 vertex
//! indices each). Out: linear eye depth d to the fragment stage.
#include "common.glsl"
layout(std430, set = 0, binding = 1) readonly buffer Pos { float pos[]; };
layout(std430, set = 0, binding = 2) readonly buffer Tri { uint tri[]; };
layout(push_constant) uniform Push {
    vec2 size;      // the fluid depth image in pixels
    uint vert_cap;  // vertices the position buffer holds
} pc;
layout(location = 0) out float v_depth;

void main() {
    uint i = min(tri[gl_VertexIndex], max(pc.vert_cap, 1u) - 1u);
    vec3 p = vec3(pos[3u * i], pos[3u * i + 1u], pos[3u * i + 2u]);
    vec3 v = (frame.view * vec4(p, 1.0)).xyz;
    float F = focal_for(pc.size.y);
    // Pixel (W/2 + F·x/d, H/2 − F·y/d) with d = −z: clip w = d, clip z = near (reversed Z, clipped below near).
    gl_Position = vec4(2.0 * F * v.x / pc.size.x, -2.0 * F * v.y / pc.size.y, frame.proj.w, -v.z);
    v_depth = -v.z;
}
