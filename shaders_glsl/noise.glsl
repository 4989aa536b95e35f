//! noise.glsl — the patent's per-particle noise kernel (NVIDIA patent US 8,947,430, eq. 15–17; method.md §8),
//! shared by noise.comp and mirrored exactly by `passes::noise::reference` (the CPU reference the tests compare
//! against).
//! A particle's sprite covers a disc of `size` radii around its centre on screen; at sprite coordinates
//! (u, v) ∈ [−1, 1]² the kernel is
//!   I = A · exp(−2(u² + v²)) · n(u, v, id) · exp(−((z − d) / (falloff · r))²)
//! with n a two-octave 3D gradient noise (Perlin 2002) whose first two coordinates are the sprite's and whose
//! third is the particle's (a per-particle offset hashed from its id, so the pattern differs per particle and
//! stays with the particle from frame to frame), z the particle's eye depth, d the surface's depth at the
//! pixel (deep particles add nothing) and A the particle's amplitude: `calm`, raised towards `turbulent` while its
//! velocity changes faster than `threshold` (eq. 17, as a smooth ramp from ½ to 1½ of the threshold so a
//! particle near it does not flicker between two levels).

/// Depth below the surface, in falloffs, past which a particle adds nothing (see noise.comp).
#define NOISE_DEEP 4.0

/// Depth below the surface, in falloffs, past which a particle of amplitude `amp` adds nothing: its term
/// amp · exp(−2q) · n · exp(−below²) (|n| < 2) is then under half a fixed-point unit (2^−16 radii) and rounds to 0,
/// so the cut is exact. At most NOISE_DEEP.
float noise_reach(float amp) {
    return sqrt(clamp(log(4.0 * amp * 65536.0), 0.0, NOISE_DEEP * NOISE_DEEP));
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

/// Perlin's improved gradient (12 cube-edge directions, 16 cases) dotted with the offset f.
float noise_grad(uint h, vec3 f) {
    uint k = h & 15u;
    float u = k < 8u ? f.x : f.y;
    float v = k < 4u ? f.y : ((k == 12u || k == 14u) ? f.x : f.z);
    return ((k & 1u) == 0u ? u : -u) + ((k & 2u) == 0u ? v : -v);
}

float noise_corner(ivec3 c, vec3 f) {
    return noise_grad(noise_hash(uint(c.x) ^ noise_hash(uint(c.y) ^ noise_hash(uint(c.z)))), f);
}

/// 3D gradient noise in about [−1, 1], 0 on the integer lattice.
float noise_perlin(vec3 p) {
    vec3 i = floor(p);
    vec3 f = p - i;
    ivec3 c = ivec3(i);
    vec3 w = f * f * f * (f * (f * 6.0 - 15.0) + 10.0);
    float x00 = mix(noise_corner(c, f), noise_corner(c + ivec3(1, 0, 0), f - vec3(1, 0, 0)), w.x);
    float x10 = mix(noise_corner(c + ivec3(0, 1, 0), f - vec3(0, 1, 0)), noise_corner(c + ivec3(1, 1, 0), f - vec3(1, 1, 0)), w.x);
    float x01 = mix(noise_corner(c + ivec3(0, 0, 1), f - vec3(0, 0, 1)), noise_corner(c + ivec3(1, 0, 1), f - vec3(1, 0, 1)), w.x);
    float x11 = mix(noise_corner(c + ivec3(0, 1, 1), f - vec3(0, 1, 1)), noise_corner(c + ivec3(1, 1, 1), f - vec3(1, 1, 1)), w.x);
    return mix(mix(x00, x10, w.y), mix(x01, x11, w.y), w.z);
}

/// The particle's place in the noise volume: three coordinates in [0, 256) hashed from its id.
vec3 noise_offset(uint id) {
    uint s = noise_hash(id);
    return vec3(noise_hash(s) & 1023u, noise_hash(s ^ 1u) & 1023u, noise_hash(s ^ 2u) & 1023u) * 0.25;
}

/// Two octaves of the noise at sprite coordinates (u, v) of the particle whose offset is `o`.
float noise_sprite(vec2 uv, float freq, vec3 o) {
    vec3 q = vec3(uv * freq, 0.0) + o;
    return noise_perlin(q) + 0.5 * noise_perlin(2.0 * q + vec3(17.0));
}

/// The amplitude of a particle whose velocity changes at `accel` (world units / s²).
float noise_amplitude(float accel, float calm, float turbulent, float threshold) {
    return calm + (turbulent - calm) * smoothstep(0.5 * threshold, 1.5 * threshold, accel);
}
