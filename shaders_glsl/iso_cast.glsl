//! iso_cast.glsl — the per-pixel march of the `iso` pass (see iso.comp), shared by iso.comp (isotropic
//! kernels) and iso_aniso.comp (anisotropic kernels: the field is chosen at compile time, because a run-time
//! branch in the innermost loop doubled the cast's cost on lavapipe).
//! Two dispatches (ISO_REST picks the second): the first marches every pixel for at most pc.steps.w samples and
//! appends the rays still unfinished, with their march state, to a queue; the second (dispatched indirectly,
//! 1D) finishes the queued rays. Why: lavapipe runs 8 neighbouring pixels in the lanes of one SIMD vector, and
//! a vector runs until its slowest lane is done. On the dam-break frame (960×540) the median hit takes 3 samples
//! but 1 % take 30–100 (grazing rays along the shell between the surface and the bound spheres, in the
//! spray), so one dispatch paid 3.1× the samples it used; compacted, the long rays share vectors.
//! Queue header (binding 6): {groups x, 1, 1, count} — a VkDispatchIndirectCommand followed by the count; the
//! host zero-fills it before the first dispatch. Entries (binding 5): (pixel x | y << 16, d, previous d, φ there).
#ifdef ISO_REST
layout(local_size_x = LOCAL_1D) in;
#else
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
#endif
layout(set = 0, binding = 3, r32f) uniform image2D depth;
layout(set = 0, binding = 4, r32f) uniform readonly image2D back;
#ifdef ISO_REST
layout(std430, set = 0, binding = 5) readonly buffer IsoQueue { uvec4 iso_queue[]; };
layout(std430, set = 0, binding = 6) readonly buffer IsoArgs { uint iso_args[4]; };
#else
layout(std430, set = 0, binding = 5) writeonly buffer IsoQueue { uvec4 iso_queue[]; };
layout(std430, set = 0, binding = 6) buffer IsoArgs { uint iso_args[4]; };
#endif

struct Ray {
    vec3 eye;
    vec3 dir;    // through the pixel, unnormalised (depth d is at eye + dir * d)
    float len;   // |dir|
    float end;   // the march ends past this depth
};

Ray ray_through(ivec2 p, ivec2 size) {
    Ray r;
    r.dir = mat3(frame.inv_view) * pixel_dir(vec2(p), vec2(size), focal_for(float(size.y)));
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
        float phi = iso_sum(r.eye + r.dir * d, true, dmin);
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
                    fa = iso_sum(r.eye + r.dir * a, true, unused);
                }
                if (fa >= threshold) { result = a; return true; }
            }
            for (uint j = 0u; j < pc.steps.y; ++j) {
                float m = 0.5 * (a + b);
                float unused;
                float fm = iso_sum(r.eye + r.dir * m, true, unused);
                if (fm >= threshold) { b = m; fb = fm; } else { a = m; fa = fm; }
            }
            result = a + (b - a) * clamp((threshold - fa) / max(fb - fa, 1e-12), 0.0, 1.0);
            return true;
        }
        prev = d;
        phi_prev = phi;
        d += max(dmin - pc.params.w, k >= ISO_SHORT_STEPS ? 2.0 * pc.params.z : pc.params.z) / r.len;
    }
    return k1 >= pc.steps.x;
}

#ifndef ISO_REST
void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    // The indirect dispatch's y and z (x and the count are counted up from the host's zeros).
    if (p == ivec2(0)) { iso_args[1] = 1u; iso_args[2] = 1u; }
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
    uint at = atomicAdd(iso_args[3], 1u);
    if (at % LOCAL_1D == 0u) atomicAdd(iso_args[0], 1u);
    iso_queue[at] = uvec4(uint(p.x) | (uint(p.y) << 16), floatBitsToUint(d), floatBitsToUint(prev),
                          floatBitsToUint(phi_prev));
}
#else
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= iso_args[3]) return;
    uvec4 q = iso_queue[i];
    ivec2 p = ivec2(q.x & 0xffffu, q.x >> 16);
    Ray r = ray_through(p, imageSize(depth));
    float d = uintBitsToFloat(q.y), prev = uintBitsToFloat(q.z), phi_prev = uintBitsToFloat(q.w), result;
    march(r, pc.steps.w, pc.steps.x, d, prev, phi_prev, result);
    imageStore(depth, p, vec4(result));
}
#endif
