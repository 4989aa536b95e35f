//! splat_raster.glsl — the rasterised splat variants (measured against the compute splat by `meniscus bench`):
//! one screen-aligned quad (6 vertices) or one point sprite per particle covering the sphere's pixel bounds,
//! and a fragment shader that intersects each pixel's ray with the sphere exactly (as the compute splat does)
//! and outputs linear eye depth. Depth-tested variants write reversed-Z `near / d` to a D32 buffer
//! (GREATER test); the MIN-blend variant has no depth buffer and blends linear depth with MIN (blub).
layout(std430, set = 0, binding = 1) readonly buffer Particles { vec4 particles[]; };
layout(push_constant) uniform Push {
    uint count;
    float radius_scale;
    vec2 size;          // fluid image size in pixels
} pc;
