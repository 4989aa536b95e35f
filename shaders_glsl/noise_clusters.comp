#version 460
//! noise_clusters — the per-sprite noise splat's (CPU drivers) cull by clusters of nearby particles, so a frame
//! touches only the particles of clusters that may draw (NVIDIA patent US 8,947,430, eq. 15–17; method.md §8; the
//! cull itself is noise_splat.glsl's `noise_sprite_at`, unchanged). A cluster is at most LOCAL_1D particles of
//! one cell of a coarse grid (`compute::grid`, cells of `passes::noise::CLUSTER_SIDE` radii) with their tight
//! bounding box; it is culled whole only where every particle in it would be culled alone, so the sprites listed
//! are exactly the full cull's (test: gpu_passes `noise_clusters_list_what_the_full_cull_lists`). Why: on
//! lavapipe the cull of every particle costs about as much as loading it (7 ms for the waterfall's 814 k, its cull
//! 12–20 ms), while most particles lie off screen or deeper below the surface than their term reaches
//! (docs/gpu-frame.md). Three variants (build.rs):
//! - NOISE_CLUSTERS_BUILD, once per particle set (`passes::noise::Clusters`): one invocation per grid cell cuts
//!   its sorted particles into clusters and appends each one's record (lo.xyz, first sorted place; hi.xyz, count)
//!   and the test's indirect dispatch. In: particles, the grid's counts, start and order. Out: records, header.
//! - NOISE_CLUSTERS_DEPTH, each frame: the farthest fluid depth of every NOISE_CLUSTER_TILE² pixel tile (+inf
//!   where a pixel holds no fluid). In: the fluid depth. Out: the tiles.
//! - NOISE_CLUSTERS_TEST, each frame: one invocation per cluster keeps it unless its box lies behind the near
//!   plane, off screen by more than its largest sprite, or — every pixel its particles' centres can fall on
//!   holding fluid — deeper below the farthest of them than a sprite's cut (`NOISE_DEEP` falloffs plus the
//!   sprite's radius, noise_sprite_at's rule); the kept clusters' particle indices are appended, packed, with
//!   noise_cull's indirect dispatch over them (NOISE_CULL_CLUSTERS). In: frame, records, header, tiles, the
//!   grid's order. Out: kept.
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "common.glsl"
#include "noise.glsl"
layout(local_size_x = LOCAL_1D) in;

#if defined(NOISE_CLUSTERS_BUILD)
layout(std430, set = 0, binding = 1) readonly buffer Particles { vec4 particles[]; };
layout(std430, set = 0, binding = 2) readonly buffer Counts { uint counts[]; };
layout(std430, set = 0, binding = 3) readonly buffer Start { uint start[]; };
layout(std430, set = 0, binding = 4) readonly buffer Order { uint order[]; };
layout(std430, set = 0, binding = 5) writeonly buffer Records { vec4 records[]; };
// {work groups x, 1, 1, clusters}: the test's indirect dispatch (zero-filled by the host before the build).
layout(std430, set = 0, binding = 6) buffer Header { uint header[4]; };
layout(push_constant) uniform Push { uint cells; } pc;

void main() {
    uint c = gl_GlobalInvocationID.x;
    if (c == 0u) { header[1] = 1u; header[2] = 1u; }
    if (c >= pc.cells) return;
    uint n = counts[c], s = start[c];
    for (uint first = 0u; first < n; first += LOCAL_1D) {
        uint len = min(n - first, LOCAL_1D);
        vec3 lo = vec3(INF), hi = vec3(-INF);
        for (uint j = 0u; j < len; ++j) {
            vec3 p = particles[order[s + first + j]].xyz;
            lo = min(lo, p);
            hi = max(hi, p);
        }
        uint at = atomicAdd(header[3], 1u);
        if (at % LOCAL_1D == 0u) atomicAdd(header[0], 1u);
        records[2u * at] = vec4(lo, uintBitsToFloat(s + first));
        records[2u * at + 1u] = vec4(hi, uintBitsToFloat(len));
    }
}

#elif defined(NOISE_CLUSTERS_DEPTH)
layout(set = 0, binding = 1, r32f) uniform readonly image2D depth;
layout(std430, set = 0, binding = 2) writeonly buffer Tiles { float tiles[]; };

void main() {
    ivec2 size = imageSize(depth);
    int across = (size.x + int(NOISE_CLUSTER_TILE) - 1) / int(NOISE_CLUSTER_TILE);
    int down = (size.y + int(NOISE_CLUSTER_TILE) - 1) / int(NOISE_CLUSTER_TILE);
    int t = int(gl_GlobalInvocationID.x);
    if (t >= across * down) return;
    ivec2 lo = ivec2(t % across, t / across) * int(NOISE_CLUSTER_TILE);
    ivec2 hi = min(lo + int(NOISE_CLUSTER_TILE), size);
    float far = 0.0;
    for (int y = lo.y; y < hi.y; ++y) {
        for (int x = lo.x; x < hi.x; ++x) {
            float d = imageLoad(depth, ivec2(x, y)).x;
            far = is_fluid(d) ? max(far, d) : INF;
        }
        if (!is_fluid(far)) break;
    }
    tiles[t] = far;
}

#elif defined(NOISE_CLUSTERS_TEST)
layout(std430, set = 0, binding = 1) readonly buffer Records { vec4 records[]; };
layout(std430, set = 0, binding = 2) readonly buffer Header { uint header[4]; };
layout(std430, set = 0, binding = 3) readonly buffer Tiles { float tiles[]; };
// {work groups x, 1, 1, particles}: noise_cull's indirect dispatch over the kept clusters' particles (LOCAL_1D
// each; zero-filled each frame), then those particles' indices from [4] on.
layout(std430, set = 0, binding = 4) buffer Kept { uint kept[]; };
layout(set = 0, binding = 5, r32f) uniform readonly image2D depth;
layout(std430, set = 0, binding = 6) readonly buffer Order { uint order[]; };
#include "noise_push.glsl"

/// Whether no particle inside the box lo … hi can draw a sprite (noise_sprite_at would return false for each).
bool culled(vec3 lo, vec3 hi, ivec2 size) {
    float F = focal_for(float(size.y));
    float r = frame.fluid.x;
    float near = frame.proj.w;
    float zmin = INF, zmax = -INF;
    vec2 pmin = vec2(INF), pmax = vec2(-INF);
    for (uint k = 0u; k < 8u; ++k) {
        vec3 corner = mix(lo, hi, vec3(uvec3(k, k >> 1, k >> 2) & 1u));
        vec3 c = (frame.view * vec4(corner, 1.0)).xyz;
        float z = -c.z;
        zmin = min(zmin, z);
        zmax = max(zmax, z);
        vec2 at = vec2(0.5 * size.x + F * c.x / z - 0.5, 0.5 * size.y - F * c.y / z - 0.5);
        pmin = min(pmin, at);
        pmax = max(pmax, at);
    }
    // Every particle behind the near plane (noise_sprite_at: s.z <= near). The box's eye depths are its corners'
    // (a linear function's extremes); a margin covers the particles' own rounding.
    float eps = 1e-5 * (abs(zmin) + abs(zmax)) + 1e-6;
    if (zmax + eps <= near) return true;
    // Straddling the near plane (or NaN): the projection is no bound.
    if (!(zmin - eps > near)) return false;
    // With every corner in front, the particles' centres lie in the corners' projected rectangle (a box's
    // perspective image is the hull of its corners' images), grown by a margin for rounding.
    pmin -= 0.01;
    pmax += 0.01;
    // Off screen: no texel of any level within a sprite's radius (its largest at the nearest depth, on its
    // coarsest level) — noise_rect's texels lie within [0, size + 2^L).
    float R = F * pc.size * r / zmin;
    float m = R + float(1 << noise_level(R, pc.freq, pc.lod)) + 1.0;
    if (any(lessThan(pmax + m, vec2(0.0))) || any(greaterThan(pmin - m, vec2(size)))) return true;
    // Deep: the pixels the centres round to (clamped to the image, as noise_sprite_at does), every one holding
    // fluid nearer than zmin by more than the cut.
    ivec2 a = clamp(ivec2(round(pmin)), ivec2(0), size - 1), b = clamp(ivec2(round(pmax)), ivec2(0), size - 1);
    float cut = (NOISE_DEEP * pc.falloff + pc.size) * r;
    // A few pixels: read them (a tile's farthest depth on a slanted surface lies far behind its nearest pixel).
    if ((b.x - a.x + 1) * (b.y - a.y + 1) <= int(NOISE_CLUSTER_TILES_MAX)) {
        float far = 0.0;
        for (int y = a.y; y <= b.y; ++y) {
            for (int x = a.x; x <= b.x; ++x) far = max(far, imageLoad(depth, ivec2(x, y)).x);
        }
        return is_fluid(far) && zmin - eps - far > cut;
    }
    ivec2 ta = a / int(NOISE_CLUSTER_TILE), tb = b / int(NOISE_CLUSTER_TILE);
    if ((tb.x - ta.x + 1) * (tb.y - ta.y + 1) > int(NOISE_CLUSTER_TILES_MAX)) return false;
    int across = (size.x + int(NOISE_CLUSTER_TILE) - 1) / int(NOISE_CLUSTER_TILE);
    float far = 0.0;
    for (int y = ta.y; y <= tb.y; ++y) {
        for (int x = ta.x; x <= tb.x; ++x) far = max(far, tiles[y * across + x]);
    }
    return is_fluid(far) && zmin - eps - far > cut;
}

void main() {
    uint k = gl_GlobalInvocationID.x;
    if (k == 0u) { kept[1] = 1u; kept[2] = 1u; }
    bool keep = k < header[3] && !culled(records[2u * k].xyz, records[2u * k + 1u].xyz, imageSize(depth));
    // The kept clusters' particles packed one after another (the cull's lanes are then all particles: a work group
    // per cluster left most lanes of a sparse cluster idle, which lavapipe pays for as for busy ones).
    uint n = keep ? floatBitsToUint(records[2u * k + 1u].w) : 0u;
    uint offset = subgroupExclusiveAdd(n), total = subgroupAdd(n);
    uint first = 0u;
    if (subgroupElect() && total > 0u) {
        first = atomicAdd(kept[3], total);
        atomicMax(kept[0], (first + total + LOCAL_1D - 1u) / LOCAL_1D);
    }
    first = subgroupBroadcastFirst(first);
    uint s = keep ? floatBitsToUint(records[2u * k].w) : 0u;
    for (uint j = 0u; j < n; ++j) kept[4u + first + offset + j] = order[s + j];
}
#endif
