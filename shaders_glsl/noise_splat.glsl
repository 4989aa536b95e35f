//! noise_splat.glsl — one particle's noise sprite and one texel's term, shared by the splats of the `noise` pass
//! (noise.comp: every sprite by its own thread, with atomics; noise_bin.comp + noise_gather.comp: sprites binned
//! to tiles, each tile's texels summed by its own work group, no atomics). The sums are the same either way.
//! Expects, declared before it: the particle buffer `particles`, the fluid depth image `depth`, and the push
//! block `pc` (count, size, freq, falloff, calm, turbulent, threshold, tiles, small, lod); with NOISE_TERM_ONLY defined only
//! the texel term (`noise_term`), which needs `pc` alone. `noise_splat_alone` needs the atlas `accum` too (left out
//! with NOISE_CULL_ONLY: noise_cull.comp). NVIDIA patent US 8,947,430 (eq.
//! 15–17); the level of detail and the depth cut are noise.glsl's.

/// A particle's sprite: centre (full-resolution pixels), radius R (pixels), eye depth z, noise offset o,
/// amplitude, reach (falloffs), its level L and the level's texel rectangle [lo, hi].
struct Sprite {
    vec2 centre;
    float R;
    float z;
    vec3 o;
    float amp;
    float reach;
    int L;
    ivec2 lo;
    ivec2 hi;
};

#ifndef NOISE_TERM_ONLY
/// Particle i's sprite on a `size` output, its place alone (centre, R, z, level, rectangle: what the cull needs);
/// false when it draws nothing (isolated, behind the camera, off screen, too large, or deep: more than DEEP
/// falloffs plus the sprite's radius below the surface at its centre — the reference's rule).
bool noise_sprite_at(uint i, ivec2 size, out Sprite s) {
    Particle pt = load_particle(particles[i], 1.0);
    s.z = -pt.c.z;
    // An isolated particle is drawn apart from the surface: it adds no waves to it.
    if (pt.isolated || s.z <= frame.proj.w) return false;
    float F = focal_for(float(size.y));
    float r = frame.fluid.x;
    // Sprite centre and radius in pixels (pixel_dir's convention: pixel p's centre is at p + 0.5).
    s.centre = vec2(0.5 * size.x + F * pt.c.x / s.z - 0.5, 0.5 * size.y - F * pt.c.y / s.z - 0.5);
    s.R = F * pc.size * r / s.z;
    s.L = noise_level(s.R, pc.freq, pc.lod);
    noise_rect(s.centre, s.R, s.L, size, s.lo, s.hi);
    if (any(greaterThan(s.lo, s.hi)) || over_budget(s.lo, s.hi)) return false;
    ivec2 mid = clamp(ivec2(round(s.centre)), ivec2(0), size - 1);
    float dc = imageLoad(depth, mid).x;
    return !(is_fluid(dc) && s.z - dc > (NOISE_DEEP * pc.falloff + pc.size) * r);
}

/// Particle i's sprite on a `size` output, place and look (amplitude, reach, noise offset); false when it draws
/// nothing (`noise_sprite_at`). Only a sprite that draws reads its motion and hashes its id (most particles of a
/// large set are culled: off screen or deep).
bool noise_sprite_of(uint i, ivec2 size, out Sprite s) {
    if (!noise_sprite_at(i, size, s)) return false;
    vec4 motion = particles[particle_motion(pc.count, i)];
    s.amp = noise_amplitude(motion.y, pc.calm, pc.turbulent, pc.threshold);
    s.reach = noise_reach(s.amp);
    s.o = noise_offset(floatBitsToUint(motion.x));
    return true;
}

#endif

/// The pixel whose depth level L's texel q reads.
ivec2 noise_pick(ivec2 q, int L, ivec2 size) {
    return L == 0 ? q : min(q * (1 << L) + (1 << (L - 1)), size - 1);
}

/// The fixed-point term of sprite (centre, R, z, o, amp, reach) at level L's texel q whose depth pixel holds the
/// fluid at d; false (and 0) outside the sprite's disc or past its reach, where the noise is not evaluated.
bool noise_term(ivec2 q, int L, vec2 centre, float R, float z, vec3 o, float amp, float reach, float d,
                out int units) {
    units = 0;
    vec2 pos = L == 0 ? vec2(q) : (vec2(q) + 0.5) * float(1 << L) - 0.5;
    vec2 uv = (pos - centre) / R;
    float qq = dot(uv, uv);
    if (qq > 1.0) return false;
    float below = (z - d) / (pc.falloff * frame.fluid.x);
    if (below > reach) return false;
    float v = amp * exp(-2.0 * qq) * noise_sprite(uv, pc.freq, o) * exp(-below * below);
    units = int(round(v * float(DETAIL_UNITS)));
    return true;
}

#if !defined(NOISE_TERM_ONLY) && !defined(NOISE_CULL_ONLY)
/// Add sprite s's terms to the accumulator atlas `accum` (declared before this file) with one atomic per texel
/// whose term is not 0, its own thread walking its rectangle; returns the texels whose noise was evaluated.
uint noise_splat_alone(Sprite s, ivec2 size) {
    ivec2 base = noise_level_base(size, s.L);
    uint evaluated = 0u;
    for (int y = s.lo.y; y <= s.hi.y; ++y) {
        for (int x = s.lo.x; x <= s.hi.x; ++x) {
            ivec2 q = ivec2(x, y);
            float d = imageLoad(depth, noise_pick(q, s.L, size)).x;
            if (!is_fluid(d)) continue;
            int units;
            if (noise_term(q, s.L, s.centre, s.R, s.z, s.o, s.amp, s.reach, d, units)) {
                ++evaluated;
                if (units != 0) imageAtomicAdd(accum, base + q, uint(units));
            }
        }
    }
    return evaluated;
}
#endif
