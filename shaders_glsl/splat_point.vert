#version 460
//! splat_point (vertex) — point sprites: one point per particle, sized to the larger side of the sphere's pixel
//! bounds (limited by the device's maximum point size: larger spheres are clipped). See splat_raster.glsl.
#include "common.glsl"
#include "sphere.glsl"
#include "splat_raster.glsl"
layout(location = 0) flat out vec4 v_sphere;

void main() {
    vec4 pr = particles[gl_VertexIndex];
    gl_Position = vec4(2.0, 2.0, 0.5, 1.0);
    gl_PointSize = 1.0;
    v_sphere = vec4(0.0);
    Particle pt = load_particle(pr, pc.radius_scale);
    if (pt.isolated) return;
    vec3 c = pt.c;
    float r = pt.r;
    float near = frame.proj.w;
    ivec2 lo, hi;
    if (!sphere_bounds(c, r, pc.size, focal_for(pc.size.y), near, lo, hi)) return;
    vec2 centre = 0.5 * (vec2(lo) + vec2(hi + 1));
    gl_PointSize = float(max(hi.x - lo.x, hi.y - lo.y) + 1);
    float z = near / max(-c.z - r, near);
    gl_Position = vec4(centre / pc.size * 2.0 - 1.0, z, 1.0);
    v_sphere = vec4(c, r);
}
