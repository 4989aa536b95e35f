//! iso_cast.glsl — the per-pixel march of the `iso` pass (see iso.comp), shared by iso.comp (isotropic
//! kernels) and iso_aniso.comp (anisotropic kernels: the field is chosen at compile time, because a run-time
//! branch in the innermost loop doubled the cast's cost on lavapipe).
//! Two dispatches (ISO_REST picks the second): the first marches every pixel for at most pc.steps.w samples and
//! appends the rays still unfinished, with their march state, to a queue; the second (dispatched indirectly,
//! 1D) finishes the queued rays. Why: lavapipe runs 8 neighbouring pixels in the lanes of one SIMD vector, and
//! a vector runs until its slowest lane is done. On the dam-break frame (960×540) the median hit takes 3 samples
//! but 1 % take 30–100 (grazing rays along the shell between the surface and the bound spheres, in the
//! spray), so one dispatch paid 3.1× the samples it used; compacted, the long rays share vectors.
//! Queue header (binding 6): two rounds of {groups x, 1, 1, count} — a VkDispatchIndirectCommand followed by the
//! count — then round 0's wide dispatches {groups x, 1, 1, unused} with 8 and with 32 lanes per ray; the host
//! zero-fills it before the first dispatch. Entries (binding 5): (pixel x | y << 16, d,
//! previous d, φ there); round 0 (the first dispatch's rays, continued from sample pc.steps.w) from entry 0,
//! round 1 (the fine dispatch's fallbacks, marched from the start) after round 0's.
//! Coarse-to-fine (pc.fine.x > 0: the host turns it on for a frame whose nearest particle is at least
//! [iso] fine_px pixels in radius on screen; isotropic kernels only). Where a particle is that large, only the
//! pixels with even x and y march (iso_blocks.comp replaces iso.comp as the first dispatch, one invocation per
//! 2×2 block). Then iso_fine.comp runs twice: phase 0 gives each marched pixel one Newton step of the field
//! along its ray (φ and ∇φ in one sum); phase 1 gives every other pixel the mean depth of its 2 or 4 marched
//! neighbours, kept as it is where their second differences say it lies within ISO_FINE_FLAT of a pixel of the
//! surface, else improved by one Newton step. Where a neighbour missed, the neighbours' depths spread more than
//! pc.fine.z or the step is longer than pc.fine.w, the pixel is queued as round 1 and marched from its start by
//! a second iso_rest dispatch (≈ 5 % of the fine pixels on the worst-case block: its silhouettes and edges), so
//! those marches do not hold up the vectors of Newton steps. The issue's lever "march at reduced resolution,
//! refine at full resolution". Each step is its own dispatch because lavapipe paid for code beside the march
//! even where it never ran: a loop over the block's pixels, or the Newton step, in iso.comp cost its march
//! 35 % on the dam-break frame.
// The wide second dispatches: 8 lanes per ray for every queued ray (WIDE8), or by the queue's length (`[iso]
// rest_lanes` = 32): 32 lanes per ray when at most ISO_WIDE_SPLIT rays are queued (WIDE32), else 8 (WIDE8_MANY);
// both are dispatched and one of them finds nothing to do.
#if defined(ISO_REST_WIDE8)
#define ISO_WIDE 8u
#define ISO_REST_WIDE
#elif defined(ISO_REST_WIDE8_MANY)
#define ISO_WIDE 8u
#define ISO_REST_WIDE
#define ISO_REST_SPLIT 1
#elif defined(ISO_REST_WIDE32)
#define ISO_WIDE 32u
#define ISO_REST_WIDE
#define ISO_REST_SPLIT 0
#endif
#if defined(ISO_REST_WIDE) && !defined(ISO_REST)
#define ISO_REST
#endif
#ifdef ISO_REST
layout(local_size_x = LOCAL_1D) in;
#else
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
#endif
// The cast's own bindings follow the field's: 3 … 6 after the points and cells, 2 … 5 after the volume.
#ifndef ISO_CAST_BINDING
#define ISO_CAST_BINDING 3
#endif
layout(set = 0, binding = ISO_CAST_BINDING, r32f) uniform image2D depth;
layout(set = 0, binding = ISO_CAST_BINDING + 1, r32f) uniform readonly image2D back;
#ifdef ISO_REST
layout(std430, set = 0, binding = ISO_CAST_BINDING + 2) readonly buffer IsoQueue { uvec4 iso_queue[]; };
layout(std430, set = 0, binding = ISO_CAST_BINDING + 3) readonly buffer IsoArgs { uint iso_args[20]; };
#else
layout(std430, set = 0, binding = ISO_CAST_BINDING + 2) writeonly buffer IsoQueue { uvec4 iso_queue[]; };
layout(std430, set = 0, binding = ISO_CAST_BINDING + 3) buffer IsoArgs { uint iso_args[20]; };

/// Append pixel p's march state to the queue's round (0 or 1). Round 0 counts the work groups of each of its
/// second dispatches: one lane per ray (x at [0]), 8 lanes per ray (x at [8]) and 32 (x at [12]).
void enqueue(uint round, ivec2 p, float d, float prev, float phi_prev) {
    uint at = atomicAdd(iso_args[4u * round + 3u], 1u);
    if (at % LOCAL_1D == 0u) atomicAdd(iso_args[4u * round], 1u);
    if (round == 0u && at % (LOCAL_1D / 8u) == 0u) atomicAdd(iso_args[8], 1u);
    // The 32-lane dispatch runs only while at most ISO_WIDE_SPLIT rays are queued: past them its work groups would
    // all return at once (83 k of them for the worst case's 167 k rays at 1080p, 0.05 ms on an H100).
    if (round == 0u && at < ISO_WIDE_SPLIT && at % (LOCAL_1D / 32u) == 0u) atomicAdd(iso_args[12], 1u);
    uint base = round == 1u ? iso_args[3] : 0u;
    iso_queue[base + at] = uvec4(uint(p.x) | (uint(p.y) << 16), floatBitsToUint(d), floatBitsToUint(prev),
                                 floatBitsToUint(phi_prev));
}
#endif

// The pass's work (bench's `iso_work`): [0] field samples, summed over the dispatches of a frame (every
// invocation's own evaluations of φ, the wide dispatch's lanes each, bisections and Newton steps included;
// IsoQueue::work reads it, the host zeroes it with the queue's header). After the field's bindings.
#if defined(ISO_ANISO_BINDING)
#define ISO_WORK_BINDING (ISO_ANISO_BINDING + 1)
#elif defined(ISO_VOLUME)
#define ISO_WORK_BINDING 9
#else
#define ISO_WORK_BINDING (ISO_CAST_BINDING + 4)
#endif
layout(std430, set = 0, binding = ISO_WORK_BINDING) buffer IsoWork { uint iso_work[4]; };
#if !defined(ISO_REST) && !defined(ISO_FINE) && !defined(ISO_BLOCKS)
// The first dispatch's tiles (iso_tiles.comp): one work group per tile of the bound spheres' depth that holds
// fluid (x | y << 16, in tiles of LOCAL_2D × LOCAL_2D pixels).
layout(std430, set = 0, binding = ISO_WORK_BINDING + 1) readonly buffer IsoTiles { uint iso_tiles[]; };
#endif
#include "work_count.glsl"
/// This invocation's field samples so far (added to iso_work[0] once per subgroup, when it returns).
uint g_samples = 0u;

/// φ at x (iso_field.glsl's iso_sum), counted.
float cast_sum(vec3 x, bool skip, out float dmin) {
    g_samples += 1u;
    return iso_sum(x, skip, dmin);
}

struct Ray {
    vec3 eye;
    vec3 dir;    // through the pixel, unnormalised (depth d is at eye + dir * d)
    float len;   // |dir|
    float end;   // the march ends past this depth
    float focal; // focal length, pixels
};

Ray ray_through(ivec2 p, ivec2 size) {
    Ray r;
    r.focal = focal_for(float(size.y));
    r.dir = mat3(frame.inv_view) * pixel_dir(vec2(p), vec2(size), r.focal);
    r.eye = frame.eye.xyz;
    r.len = length(r.dir);
    // Where the ray leaves the grid's box grown by the support (no field beyond it).
    vec3 lo = pc.origin.xyz - pc.params.x;
    vec3 hi = pc.origin.xyz + vec3(pc.dims.xyz) * pc.origin.w + pc.params.x;
    vec3 safe = mix(r.dir, vec3(1e-12), lessThan(abs(r.dir), vec3(1e-12)));
    vec3 t0 = (lo - r.eye) / safe, t1 = (hi - r.eye) / safe;
    vec3 tf = max(t0, t1);
    r.end = min(tf.x, min(tf.y, tf.z));
    // The far bound: the farthest sphere exit of the pixel (pc.steps.z = 1, from the splat) or of its 8×8 tile
    // (2, from `splat_cull`: no bound sphere touching the tile reaches deeper).
    if (pc.steps.z == 1u) r.end = min(r.end, imageLoad(back, p).x);
    if (pc.steps.z == 2u) r.end = min(r.end, imageLoad(back, p / int(SPLAT_TILE)).x);
    return r;
}

/// Coarse-to-fine is on and a particle at depth d is at least its least radius on screen (pc.fine.x = radius ÷
/// least pixels).
bool fine_scale(float d, float focal) { return pc.fine.x > 0.0 && pc.fine.x * focal >= d; }

#if !defined(ISO_ANISO_BINDING) && !defined(ISO_VOLUME)
/// One Newton step of φ along the ray from depth z (φ and ∇φ in one sum); ok: the field rises into the water
/// there and the step is at most pc.fine.w.
float newton(Ray r, float z, out bool ok) {
    vec3 grad;
    g_samples += 1u;
    float phi = iso_sum_grad(r.eye + r.dir * z, grad);
    float slope = dot(grad, r.dir);
    float step = (pc.params.y - phi) / slope;
    ok = slope > 0.0 && abs(step) <= pc.fine.w;
    return z + step;
}
#endif

/// The crossing inside the bracket [a, b] (φ(a) = fa below the threshold, φ(b) = fb at or above it): pc.steps.y
/// bisections, then one linear interpolation. Shared by the one-lane and the wide march.
float bracket_depth(Ray r, float a, float b, float fa, float fb) {
    float threshold = pc.params.y;
    for (uint j = 0u; j < pc.steps.y; ++j) {
        float m = 0.5 * (a + b);
        float unused;
        float fm = cast_sum(r.eye + r.dir * m, true, unused);
        if (fm >= threshold) { b = m; fb = fm; } else { a = m; fa = fm; }
    }
    return a + (b - a) * clamp((threshold - fa) / max(fb - fa, 1e-12), 0.0, 1.0);
}

// March samples k0 … k1 − 1 from depth d (prev, phi_prev: the sample before; k0 = 0: d is the start). The
// smallest step doubles after ISO_SHORT_STEPS samples: a ray that long grazes the shell between the surface and
// the bound spheres (iso −5 % on the dam-break frame, normals unchanged: tools/quality.sh). True
// when the ray is done, with `result` its surface depth or INF (no crossing before the far bound or the most
// steps pc.steps.x); false when it ran out of samples first (the state then continues it).
bool march(Ray r, uint k0, uint k1, inout float d, inout float prev, inout float phi_prev, out float result) {
    float threshold = pc.params.y;
    float near = frame.proj.w;
    result = INF;
    for (uint k = k0; k < k1; ++k) {
        if (d > r.end) return true;
        float dmin;
        float phi = cast_sum(r.eye + r.dir * d, true, dmin);
        if (phi >= threshold) {
            float a = prev, b = d, fa = phi_prev, fb = phi;
            if (k == 0u) {
                // Started inside: the surface bulges past the bound sphere here. Step back towards the eye (at
                // most ISO_BACK_STEPS smallest steps, not past the near plane) to bracket the crossing.
                a = d;
                fa = phi;
                for (uint j = 0u; j < ISO_BACK_STEPS && fa >= threshold && a > near; ++j) {
                    b = a;
                    fb = fa;
                    a = max(a - pc.params.z / r.len, near);
                    float unused;
                    fa = cast_sum(r.eye + r.dir * a, true, unused);
                }
                if (fa >= threshold) { result = a; return true; }
            }
            result = bracket_depth(r, a, b, fa, fb);
            return true;
        }
        prev = d;
        phi_prev = phi;
        d += max(dmin - pc.params.w, k >= ISO_SHORT_STEPS ? 2.0 * pc.params.z : pc.params.z) / r.len;
    }
    return k1 >= pc.steps.x;
}

/// Whether pixel p (depth d of the bound spheres, focal length F pixels) is left to the fine dispatch: off the
/// even lattice, where a particle at depth d is large enough on screen (fine_scale).
bool fine_pixel(ivec2 p, float d, float F) {
    return ((p.x | p.y) & 1) != 0 && fine_scale(d, F);
}

/// With coarse-to-fine on, an invocation of iso_blocks.comp and iso_fine.comp owns a 2×2 block of pixels (the
/// marched pixel at its even corner, k = 0), so the 8 lanes of a SIMD vector stay busy.
ivec2 block_pixel(uint k) { return 2 * ivec2(gl_GlobalInvocationID.xy) + ivec2(k & 1u, k >> 1); }

#if defined(ISO_FINE)
// Where the marched neighbours' second differences say their mean is within this fraction of a pixel's width
// (in depth) of the surface, the mean is kept without a Newton step.
#ifndef ISO_FINE_FLAT
#define ISO_FINE_FLAT 0.01
#endif
/// Pixel p (a fine pixel: its bound spheres' depth d) from its marched neighbours; INF when it must be marched.
float fine_depth(ivec2 p, ivec2 size, float d) {
    Ray r = ray_through(p, size);
    // The marched neighbours: left and right (odd x, even y), above and below (even x, odd y), or the four
    // diagonals (both odd; then n2, n3 are the other two corners, else repeats of n1, n0).
    ivec2 o = p & 1;
    ivec2 n0 = p - o, n1 = p + o, n2 = p + ivec2(o.x, -o.y), n3 = p + ivec2(-o.x, o.y);
    if (all(lessThan(max(n1, n2), size))) {
        vec4 nd = vec4(imageLoad(depth, n0).x, imageLoad(depth, n1).x, imageLoad(depth, n2).x, imageLoad(depth, n3).x);
        float lo = min(min(nd.x, nd.y), min(nd.z, nd.w)), hi = max(max(nd.x, nd.y), max(nd.z, nd.w));
        if (is_fluid(hi) && hi - lo <= pc.fine.z) {
            float mean = 0.25 * (nd.x + nd.y + nd.z + nd.w);
            // The mean's error where the surface is a quadratic a x² + b y² + c x y + …: a + b (x, y in units of
            // 2 pixels), from the second differences along the marched row above (or through) p and the
            // marched column left of (or through) p: d(−3) − d(−1) − d(1) + d(3) = 16 a.
            ivec2 c = p - o;
            float e = all(greaterThanEqual(c, ivec2(2) * o)) && all(lessThan(c + ivec2(4) * o, size)) ? 0.0 : INF;
            if (o.x == 1) e += imageLoad(depth, c + ivec2(-2, 0)).x - nd.x - imageLoad(depth, c + ivec2(2, 0)).x
                               + imageLoad(depth, c + ivec2(4, 0)).x;
            if (o.y == 1) e += imageLoad(depth, c + ivec2(0, -2)).x - nd.x - imageLoad(depth, c + ivec2(0, 2)).x
                               + imageLoad(depth, c + ivec2(0, 4)).x;
            if (abs(e) <= 16.0 * ISO_FINE_FLAT * mean / r.focal) return mean;
            bool ok;
            float z = newton(r, mean, ok);
            // Trusted when the field rises into the water, the step is short, and the surface lies before the
            // ray's far bound (where the march would stop).
            if (ok && z <= r.end) return z;
        }
    }
    return INF;
}

void cast_main() {
    ivec2 size = imageSize(depth);
    if (pc.fine.y == 0.0) {
        // Phase 0: the marched pixel gets the Newton step its fine neighbours will get; the march's linear
        // interpolation (errors up to 0.02 r) beside their Newton-exact depths would otherwise show as a
        // 2-pixel pattern in the normals. (In its own dispatch: beside the march, in the same shader, a second
        // field sum cost the cast 35 % on lavapipe even where it never ran.)
        ivec2 p = block_pixel(0u);
        if (any(greaterThanEqual(p, size))) return;
        float z = imageLoad(depth, p).x;
        if (!is_fluid(z) || !fine_scale(z, focal_for(float(size.y)))) return;
        bool ok;
        float n = newton(ray_through(p, size), z, ok);
        if (ok) imageStore(depth, p, vec4(n));
        return;
    }
    // Phase 1: the fine pixels. Round 1's indirect y and z.
    if (gl_GlobalInvocationID.xy == uvec2(0)) { iso_args[5] = 1u; iso_args[6] = 1u; }
    float F = focal_for(float(size.y));
    for (uint k = 1u; k < 4u; ++k) {
        ivec2 p = block_pixel(k);
        if (any(greaterThanEqual(p, size))) continue;
        float d = imageLoad(depth, p).x;
        if (!is_fluid(d) || !fine_pixel(p, d, F)) continue;
        float f = fine_depth(p, size, d);
        if (is_fluid(f)) imageStore(depth, p, vec4(f));
        else enqueue(1u, p, d, d, 0.0);
    }
}
#elif defined(ISO_BLOCKS)
void cast_main() {
    // The first dispatch with coarse-to-fine on (iso_blocks.comp): the block's marched pixel, and those of its
    // other pixels whose particles are too small on screen for the fine dispatch.
    if (gl_GlobalInvocationID.xy == uvec2(0)) { iso_args[1] = 1u; iso_args[2] = 1u; iso_args[9] = 1u; iso_args[10] = 1u; iso_args[13] = 1u; iso_args[14] = 1u; }
    ivec2 size = imageSize(depth);
    float F = focal_for(float(size.y));
    for (uint k = 0u; k < 4u; ++k) {
        ivec2 p = block_pixel(k);
        if (any(greaterThanEqual(p, size))) continue;
        float d = imageLoad(depth, p).x;
        if (!is_fluid(d) || fine_pixel(p, d, F)) continue;
        Ray r = ray_through(p, size);
        float prev = d, phi_prev = 0.0, result;
        if (march(r, 0u, min(pc.steps.w, pc.steps.x), d, prev, phi_prev, result)) imageStore(depth, p, vec4(result));
        else enqueue(0u, p, d, prev, phi_prev);
    }
}
#elif !defined(ISO_REST)
void cast_main() {
    // One pixel per invocation (coarse-to-fine off: the shader is the lean march alone, see iso_blocks.comp),
    // one work group per tile that holds fluid (iso_tiles.comp).
    uint g = gl_WorkGroupID.y * ISO_TILE_ROW + gl_WorkGroupID.x;
    // The second dispatches' y and z (x and the count are counted up from the host's zeros).
    if (g == 0u && gl_LocalInvocationIndex == 0u) { iso_args[1] = 1u; iso_args[2] = 1u; iso_args[9] = 1u; iso_args[10] = 1u; iso_args[13] = 1u; iso_args[14] = 1u; }
    // The last row's work groups past the listed tiles have none.
    if (g >= iso_args[19]) return;
    uint tile = iso_tiles[g];
    ivec2 p = ivec2(tile & 0xffffu, tile >> 16) * int(LOCAL_2D) + ivec2(gl_LocalInvocationID.xy);
    ivec2 size = imageSize(depth);
    if (any(greaterThanEqual(p, size))) return;
    float d = imageLoad(depth, p).x;
    if (!is_fluid(d)) return;
    Ray r = ray_through(p, size);
    float prev = d, phi_prev = 0.0, result;
    if (march(r, 0u, min(pc.steps.w, pc.steps.x), d, prev, phi_prev, result)) {
        imageStore(depth, p, vec4(result));
        return;
    }
    enqueue(0u, p, d, prev, phi_prev);
}
#elif defined(ISO_REST_WIDE)
// ISO_WIDE (8 or 32) consecutive lanes of a subgroup march one ray of round 0 together (`[iso] rest_lanes`; the
// host uses a width only where the device shuffles within subgroups at least that wide that divide the work
// group: DeviceInfo::shuffle_lanes). Each step, lane l samples the ray at d + l·s (s the smallest step there)
// and the lanes vote with shuffles: the first lane past the threshold brackets the crossing with the lane before
// it (or the last step's sample); else the ray moves to the farthest point the samples show free of the surface
// — the lattice's end, or a lane's own skip (its nearest point's distance less the bound), whichever reaches
// farther. Each step is one field sample's latency for ISO_WIDE samples: a ray that takes 500 dependent samples
// alone takes about 60 steps of 8 lanes or 16 of 32 (on the H100 the queued rays' dispatch is bound by its
// longest ray, not by the number of rays). The bracket is refined by bracket_depth, by every lane alike.
uint lane_of(uint l) { return (gl_SubgroupInvocationID & ~(ISO_WIDE - 1u)) | l; }
uint wide_min(uint x) {
    for (uint m = 1u; m < ISO_WIDE; m <<= 1) x = min(x, subgroupShuffleXor(x, m));
    return x;
}
float wide_max(float x) {
    for (uint m = 1u; m < ISO_WIDE; m <<= 1) x = max(x, subgroupShuffleXor(x, m));
    return x;
}

float march_wide(Ray r, uint lane, uint k0, float d, float prev, float phi_prev) {
    float threshold = pc.params.y;
    for (uint k = k0; k < pc.steps.x; k += ISO_WIDE) {
        if (d > r.end) return INF;
        float step = k >= ISO_SHORT_STEPS ? 2.0 * pc.params.z : pc.params.z;
        float s = step / r.len;
        float dl = d + float(lane) * s;
        float dmin = 0.0, phi = 0.0;
        bool inside = dl <= r.end;
        if (inside) phi = cast_sum(r.eye + r.dir * dl, true, dmin);
        uint first = wide_min(inside && phi >= threshold ? lane : ISO_WIDE);
        // Every lane reads its neighbours' values in the same control flow (first is the same in all the ray's
        // lanes).
        float phi_before = subgroupShuffle(phi, lane_of(first == 0u ? 0u : min(first, ISO_WIDE) - 1u));
        float phi_first = subgroupShuffle(phi, lane_of(min(first, ISO_WIDE - 1u)));
        float phi_last = subgroupShuffle(phi, lane_of(ISO_WIDE - 1u));
        if (first < ISO_WIDE) {
            float a = first == 0u ? prev : d + float(first - 1u) * s, b = d + float(first) * s;
            float fa = first == 0u ? phi_prev : phi_before, fb = phi_first;
            return bracket_depth(r, a, b, fa, fb);
        }
        // No crossing among the samples; a lane past the far bound ends the ray.
        float last = d + float(ISO_WIDE - 1u) * s;
        if (last > r.end) return INF;
        float reach = wide_max(dl + max(dmin - pc.params.w, step) / r.len);
        prev = last;
        phi_prev = phi_last;
        d = reach;
    }
    return INF;
}

void cast_main() {
    // Rays of round 0, ISO_WIDE lanes each: the work group's subgroups hold LOCAL_1D / ISO_WIDE whole rays.
    uint lane = gl_SubgroupInvocationID % ISO_WIDE;
    uint i = (gl_WorkGroupID.x * gl_NumSubgroups + gl_SubgroupID) * (gl_SubgroupSize / ISO_WIDE)
             + gl_SubgroupInvocationID / ISO_WIDE;
    uint count = iso_args[3];
#ifdef ISO_REST_SPLIT
    // Few rays: 32 lanes each (the longest ray's dependent steps bound the dispatch); many: 8 lanes each (32
    // would leave most lanes waiting past short rays' crossings, and the rays no longer fit the device at once).
    if ((count > ISO_WIDE_SPLIT) != (ISO_REST_SPLIT == 1)) return;
#endif
    if (i >= count) return;
    uvec4 q = iso_queue[i];
    ivec2 p = ivec2(q.x & 0xffffu, q.x >> 16);
    Ray r = ray_through(p, imageSize(depth));
    float result = march_wide(r, lane, pc.steps.w, uintBitsToFloat(q.y), uintBitsToFloat(q.z), uintBitsToFloat(q.w));
    if (lane == 0u) imageStore(depth, p, vec4(result));
}
#else
void cast_main() {
    // Round pc.fine.y: 0 continues the first dispatch's rays, 1 marches the fine dispatch's fallbacks from the
    // start.
    bool fallbacks = pc.fine.y > 0.0;
    uint i = gl_GlobalInvocationID.x;
    if (i >= iso_args[fallbacks ? 7 : 3]) return;
    uvec4 q = iso_queue[(fallbacks ? iso_args[3] : 0u) + i];
    ivec2 p = ivec2(q.x & 0xffffu, q.x >> 16);
    Ray r = ray_through(p, imageSize(depth));
    float d = uintBitsToFloat(q.y), prev = uintBitsToFloat(q.z), phi_prev = uintBitsToFloat(q.w), result;
    march(r, fallbacks ? 0u : pc.steps.w, pc.steps.x, d, prev, phi_prev, result);
    imageStore(depth, p, vec4(result));
}
#endif

void main() {
    cast_main();
    WORK_ADD(iso_work[0], g_samples);
}
