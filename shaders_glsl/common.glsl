//! common.glsl — conventions shared by every Meniscus shader (mirrored by `src/frame.rs::FrameUniforms`).
//!
//! * View space is right-handed, the camera looks down −z (Moritz 2016 §3.1).
//! * Depth images hold LINEAR EYE DEPTH d = −z_view > 0. "No fluid" is +inf (test with `is_fluid`); the same
//!   convention `meniscus quality` (src/quality/) reads.
//! * Pixel (x, y) has its centre at (x + 0.5, y + 0.5); row 0 is the TOP row. A view-space point maps to
//!   (W/2 + F·x/d, H/2 − F·y/d) with F = H / (2 tan(fovy/2)) pixels (focal length).
//! * Binding 0 of every pass is the frame uniform block below.
//! * Colours are linear; the composite pass encodes sRGB-ish gamma into the 8-bit output.

layout(std140, set = 0, binding = 0) uniform Frame {
    mat4 view;          // world -> view
    mat4 inv_view;      // view -> world
    vec4 eye;           // xyz: camera position (world)
    vec4 proj;          // x: F in full-resolution pixels, y: W, z: H, w: near plane distance
    vec4 fluid;         // x: particle radius, y: fluid scale, z: thickness fixed-point units per world unit, w: count
    vec4 sun;           // xyz: direction towards the sun (world, unit), w: intensity
    vec4 ground;        // x: ground height (y), y: checker tile size, z: 1 if the ground exists, w: fog distance
    vec4 extinction;    // rgb: Beer-Lambert extinction per world unit (eta * scale)
    vec4 fluid_color;   // rgb: I0, light scattered out of the fluid; w: ambient light
    vec4 shading;       // x: refraction alpha (px per world unit), y: beta (max px), z: gamma (transparency), w: k_s
    vec4 shading2;      // x: shininess c, y: F0, z: sky reflection on/off, w: 1 = sky cube map loaded
    vec4 box_count;     // x: number of boxes, y: number of spheres
    vec4 box_min[MAX_BOXES];    // axis-aligned boxes of the background scene (world)
    vec4 box_max[MAX_BOXES];
    vec4 spheres[MAX_SPHERES];  // spheres of the background scene: centre (xyz, world), radius (w) — a moving body
} frame;

#include "particle_layout.glsl"

#define INF uintBitsToFloat(0x7f800000u)

bool is_fluid(float d) { return d < 1e30; }

// SSR_MISS (the `ssr` output where the reflected ray hits nothing on screen), LOCAL_2D, LOCAL_1D, MAX_BOXES, MAX_PIXELS_PER_PARTICLE, … are defined by build.rs from
// src/shader_constants.rs (one definition, shared with the Rust side).

/// View-space ray direction through pixel centre p of an image of `size`, focal `F` (pixels), with z = −1:
/// the point at linear depth d is d * dir.
vec3 pixel_dir(vec2 p, vec2 size, float F) {
    return vec3((p.x + 0.5 - 0.5 * size.x) / F, -(p.y + 0.5 - 0.5 * size.y) / F, -1.0);
}

/// Focal length in pixels of an image of height `h` (any resolution).
float focal_for(float h) { return frame.proj.x * h / frame.proj.z; }

/// Octahedral encoding of a unit normal into one uint (Cigolle et al. 2014), 2 × 16-bit snorm.
vec2 oct_wrap(vec2 v) { return (1.0 - abs(v.yx)) * vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0); }
uint pack_normal(vec3 n) {
    n /= (abs(n.x) + abs(n.y) + abs(n.z));
    vec2 e = n.z >= 0.0 ? n.xy : oct_wrap(n.xy);
    return packSnorm2x16(e);
}
vec3 unpack_normal(uint u) {
    vec2 e = unpackSnorm2x16(u);
    vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    if (n.z < 0.0) n.xy = oct_wrap(n.xy);
    return normalize(n);
}

#ifdef SKY_BINDING
/// Sky cube map (six images from files) when frame.shading2.w is 1; a 1×1 placeholder otherwise.
layout(set = 0, binding = SKY_BINDING) uniform samplerCube sky_cube;
#endif

/// The sky: the cube map when one is loaded (passes that define SKY_BINDING), else procedural — a
/// horizon-to-zenith gradient, a darker ground hemisphere — plus a sun disc with a glow either way.
vec3 sky(vec3 dir) {
    dir = normalize(dir);
    vec3 zenith = vec3(0.18, 0.36, 0.78);
    vec3 horizon = vec3(0.72, 0.82, 0.94);
    vec3 c;
    if (dir.y >= 0.0) {
        c = mix(horizon, zenith, pow(dir.y, 0.45));
    } else {
        c = mix(horizon, vec3(0.32, 0.30, 0.28), clamp(-dir.y * 3.0, 0.0, 1.0));
    }
    float s = max(dot(dir, frame.sun.xyz), 0.0);
    vec3 sun = vec3(1.0, 0.92, 0.8) * pow(s, 900.0) * 12.0 * frame.sun.w;
    c += sun + vec3(1.0, 0.92, 0.8) * pow(s, 12.0) * 0.25 * frame.sun.w;
#ifdef SKY_BINDING
    // Branch-free choice of the cube map (mix with 0 or 1 is exact): a branch on this uniform makes lavapipe 22.3
    // inline it and recompile the shader at every dispatch, keeping ~300 kB of host memory each time (issue #17).
    // Right-handed world, cube maps are left-handed: mirror z.
    vec3 cube = pow(texture(sky_cube, vec3(dir.x, dir.y, -dir.z)).rgb, vec3(2.2)) + sun;
    c = mix(c, cube, step(0.5, frame.shading2.w));
#endif
    return c;
}

/// Ray against the background's boxes and spheres: nearest entry t > 0 and its normal; false when nothing is hit.
bool hit_scenery(vec3 o, vec3 d, out float t_hit, out vec3 n_hit) {
    t_hit = INF;
    int count = int(frame.box_count.x);
    for (int i = 0; i < count; ++i) {
        vec3 inv = 1.0 / d;
        vec3 t0 = (frame.box_min[i].xyz - o) * inv;
        vec3 t1 = (frame.box_max[i].xyz - o) * inv;
        vec3 tmin = min(t0, t1), tmax = max(t0, t1);
        float tn = max(max(tmin.x, tmin.y), tmin.z);
        float tf = min(min(tmax.x, tmax.y), tmax.z);
        if (tn <= tf && tn > 0.0 && tn < t_hit) {
            t_hit = tn;
            n_hit = tn == tmin.x ? vec3(-sign(d.x), 0, 0) : (tn == tmin.y ? vec3(0, -sign(d.y), 0) : vec3(0, 0, -sign(d.z)));
        }
    }
    int spheres = int(frame.box_count.y);
    for (int i = 0; i < spheres; ++i) {
        // |o + t d − c|² = r² (d need not be unit): the nearer root in front of o.
        vec3 oc = o - frame.spheres[i].xyz;
        float a = dot(d, d), b = dot(oc, d), c = dot(oc, oc) - frame.spheres[i].w * frame.spheres[i].w;
        float disc = b * b - a * c;
        if (disc < 0.0) continue;
        float t = (-b - sqrt(disc)) / a;
        if (t > 0.0 && t < t_hit) {
            t_hit = t;
            n_hit = normalize(oc + t * d);
        }
    }
    return t_hit < INF;
}
