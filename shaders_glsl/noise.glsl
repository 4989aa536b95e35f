//! noise.glsl — the patent's per-particle noise kernel (NVIDIA patent US 8,947,430, eq. 15–17),
//! shared by noise.comp and mirrored exactly by `passes::noise::reference` (the CPU reference the tests compare
//! against).
//! A particle's sprite covers a disc of `size` radii around its centre on screen; at sprite coordinates
//! (u, v) ∈ [−1, 1]² the kernel is
//!   I = A · exp(−2(u² + v²)) · n(u, v, id) · exp(−((z − d) / (falloff · r))²)
//! with n a two-octave gradient noise (Perlin 2002's quintic fade and gradient dot products) over the sprite's
//! plane, whose lattice is the particle's: offset by a hash of its id and hashed with a seed from it, so the
//! pattern differs per particle and stays with the particle from frame to frame — the patent's per-particle third
//! noise coordinate as a seed, which needs 4 lattice corners of one hash each per octave where a 3D lattice
//! needs 8 corners of three nested hashes (the `noise` pass's evaluations, its cost on every device, 2–3× cheaper;
//! scaled by NOISE_2D_RMS so its RMS, 0.270, is the 3D slice's it replaces), z the particle's eye depth, d the
//! surface's depth at the
//! pixel (deep particles add nothing) and A the particle's amplitude: `calm`, raised towards `turbulent` while its
//! velocity changes faster than `threshold` (eq. 17, as a smooth ramp from ½ to 1½ of the threshold so a
//! particle near it does not flicker between two levels).

// NOISE_DEEP (depth below the surface, in falloffs, past which a particle adds nothing; see noise.comp) and
// NOISE_2D_RMS are shader_constants (src/shader_constants.rs), defined by build.rs.

/// Depth below the surface, in falloffs, past which a particle of amplitude `amp` adds nothing: its term
/// amp · exp(−2q) · n · exp(−below²) (|n| < 2) is then under half a fixed-point unit (2^−16 radii) and rounds to 0,
/// so the cut is exact. At most NOISE_DEEP.
float noise_reach(float amp) {
    return sqrt(clamp(log(4.0 * amp * float(DETAIL_UNITS)), 0.0, NOISE_DEEP * NOISE_DEEP));
}

/// The accumulator level a sprite of radius R pixels is evaluated on (noise.comp): the coarsest whose texels
/// (2^L pixels) still sample the finer octave (2·freq cycles per R) `samples` times per cycle ([noise]
/// lod_samples).
int noise_level(float R, float freq, float samples) {
    float texel = R / (2.0 * freq * samples);
    return texel < 2.0 ? 0 : min(int(floor(log2(texel))), int(NOISE_LEVELS));
}

/// Level L's size for a W×H image: ⌈W/2^L⌉ × ⌈H/2^L⌉.
ivec2 noise_level_size(ivec2 size, int L) {
    return (size + (1 << L) - 1) >> L;
}

/// Where level L starts in the accumulator atlas: level 0 at the origin, the coarser ones stacked to its right.
ivec2 noise_level_base(ivec2 size, int L) {
    if (L == 0) return ivec2(0);
    int y = 0;
    for (int k = 1; k < L; ++k) y += noise_level_size(size, k).y;
    return ivec2(size.x, y);
}

/// The texels of level L whose positions lie within R of a sprite's centre (full-resolution pixels), clipped to
/// the level: at level 0 the pixels, as the CPU reference walks them; texel i of level L sits at (i + ½)·2^L − ½.
void noise_rect(vec2 centre, float R, int L, ivec2 size, out ivec2 lo, out ivec2 hi) {
    float cell = float(1 << L);
    vec2 lo_f = L == 0 ? ceil(centre - R) : ceil((centre - R + 0.5) / cell - 0.5);
    vec2 hi_f = L == 0 ? floor(centre + R) : floor((centre + R + 0.5) / cell - 0.5);
    lo = max(ivec2(lo_f), ivec2(0));
    hi = min(ivec2(hi_f), noise_level_size(size, L) - 1);
}

/// Tiles (NOISE_TILE × NOISE_TILE texels) of level L: the tiled splat's bins.
ivec2 noise_tiles(ivec2 size, int L) {
    return (noise_level_size(size, L) + int(NOISE_TILE) - 1) / int(NOISE_TILE);
}

/// The index of level L's first tile (the levels' tiles are numbered level after level, rows within each).
int noise_tile_base(ivec2 size, int L) {
    int n = 0;
    for (int k = 0; k < L; ++k) {
        ivec2 t = noise_tiles(size, k);
        n += t.x * t.y;
    }
    return n;
}

/// Integer hash (lowbias32, C. Wellons): every bit of the input reaches every bit of the output.
uint noise_hash(uint x) {
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

// The 2D noise's scale NOISE_2D_RMS: its RMS (0.3045 over the lattice) brought to the 3D gradient noise's slice
// (0.2698), so the amplitudes `calm` and `turbulent` keep their meaning.

/// A lattice corner's gradient, one of the four diagonals (±1, ±1) chosen by the hash, dotted with the offset f.
float noise_grad(uint h, vec2 f) {
    return ((h & 1u) == 0u ? f.x : -f.x) + ((h & 2u) == 0u ? f.y : -f.y);
}

/// 2D gradient noise in [−1, 1] (before NOISE_2D_RMS), 0 on the integer lattice; `seed` picks the lattice's
/// gradients. Corner (x, y) hashes x·0x8da6b343 + y·0xd8163841 + seed (wrapping) once.
float noise_perlin(vec2 p, uint seed) {
    vec2 i = floor(p);
    vec2 f = p - i;
    ivec2 c = ivec2(i);
    vec2 w = f * f * f * (f * (f * 6.0 - 15.0) + 10.0);
    uint x0 = uint(c.x) * 0x8da6b343u, x1 = x0 + 0x8da6b343u;
    uint y0 = uint(c.y) * 0xd8163841u + seed, y1 = y0 + 0xd8163841u;
    float a = noise_grad(noise_hash(x0 + y0), f);
    float b = noise_grad(noise_hash(x1 + y0), f - vec2(1.0, 0.0));
    float e = noise_grad(noise_hash(x0 + y1), f - vec2(0.0, 1.0));
    float g = noise_grad(noise_hash(x1 + y1), f - vec2(1.0, 1.0));
    return mix(mix(a, b, w.x), mix(e, g, w.x), w.y);
}

/// The particle's place in the noise: a lattice offset (xy, in [0, 256)) and its seed (z: the seed ÷ 1024),
/// hashed from its id.
vec3 noise_offset(uint id) {
    uint s = noise_hash(id);
    return vec3(noise_hash(s) & 1023u, noise_hash(s ^ 1u) & 1023u, noise_hash(s ^ 2u) & 1023u) * 0.25;
}

/// Two octaves of the noise at sprite coordinates (u, v) of the particle whose offset is `o`.
float noise_sprite(vec2 uv, float freq, vec3 o) {
    vec2 q = uv * freq + o.xy;
    uint seed = uint(o.z * 4.0) * 0x9e3779b9u;
    return NOISE_2D_RMS * (noise_perlin(q, seed) + 0.5 * noise_perlin(2.0 * q + vec2(17.0), seed ^ 0x5bd1e995u));
}

/// The amplitude of a particle whose velocity changes at `accel` (world units / s²).
float noise_amplitude(float accel, float calm, float turbulent, float threshold) {
    return calm + (turbulent - calm) * smoothstep(0.5 * threshold, 1.5 * threshold, accel);
}
