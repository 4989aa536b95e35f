#version 460
//! splat_quad (vertex) — quads: 6 vertices per particle over the sphere's pixel bounds, at the depth of the
//! sphere's front (so conservative depth can promise fragments lie behind it). See splat_raster.glsl.
#include "common.glsl"
#include "sphere.glsl"
#include "splat_raster.glsl"
layout(location = 0) flat out vec4 v_sphere;

void main() {
    uint i = uint(gl_VertexIndex) / 6u;
    uint corner = uint(gl_VertexIndex) % 6u;
    vec4 pr = particles[i];
    gl_Position = vec4(2.0, 2.0, 0.5, 1.0); // culled unless set below
    v_sphere = vec4(0.0);
    Particle pt = load_particle(pr, pc.radius_scale);
    if (pt.isolated) return;
    vec3 c = pt.c;
    float r = pt.r;
    float near = frame.proj.w;
    ivec2 lo, hi;
    if (!sphere_bounds(c, r, pc.size, focal_for(pc.size.y), near, lo, hi)) return;
    // Two triangles over the pixel edges [lo, hi + 1].
    const uvec2 corners[6] = uvec2[](uvec2(0, 0), uvec2(1, 0), uvec2(0, 1), uvec2(1, 0), uvec2(1, 1), uvec2(0, 1));
    vec2 px = mix(vec2(lo), vec2(hi + 1), vec2(corners[corner]));
    float z = near / max(-c.z - r, near);
    gl_Position = vec4(px / pc.size * 2.0 - 1.0, z, 1.0);
    v_sphere = vec4(c, r);
}
