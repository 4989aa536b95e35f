//! iso_cast.glsl — the per-pixel march of the `iso` pass (see iso.comp), shared by iso.comp (isotropic
//! kernels) and iso_aniso.comp (anisotropic kernels: the field is chosen at compile time, because a run-time
//! branch in the innermost loop doubled the cast's cost on lavapipe).
layout(local_size_x = LOCAL_2D, local_size_y = LOCAL_2D) in;
layout(set = 0, binding = 4, r32f) uniform image2D depth;
layout(set = 0, binding = 5, r32f) uniform readonly image2D back;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(depth);
    if (any(greaterThanEqual(p, size))) return;
    float d0 = imageLoad(depth, p).x;
    if (!is_fluid(d0)) return;
    vec3 dir = mat3(frame.inv_view) * pixel_dir(vec2(p), vec2(size), focal_for(float(size.y)));
    vec3 eye = frame.eye.xyz;
    // Where the ray leaves the grid's box grown by the support (no field beyond it).
    vec3 lo = pc.origin.xyz - pc.params.x;
    vec3 hi = pc.origin.xyz + vec3(pc.dims.xyz) * pc.origin.w + pc.params.x;
    vec3 safe = mix(dir, vec3(1e-12), lessThan(abs(dir), vec3(1e-12)));
    vec3 t0 = (lo - eye) / safe, t1 = (hi - eye) / safe;
    vec3 tf = max(t0, t1);
    float d_end = min(tf.x, min(tf.y, tf.z));
    // The far bound: the farthest sphere exit of the pixel (pc.steps.z = 1, from the splat) or of its 8×8 tile
    // (2, from `splat_cull`: no bound sphere touching the tile reaches deeper).
    if (pc.steps.z == 1u) d_end = min(d_end, imageLoad(back, p).x);
    if (pc.steps.z == 2u) d_end = min(d_end, imageLoad(back, p / int(SPLAT_TILE)).x);
    float len = length(dir);
    float threshold = pc.params.y;
    float near = frame.proj.w;
    float d = d0, prev = d0, phi_prev = 0.0;
    float result = INF;
    for (uint k = 0u; k < pc.steps.x; ++k) {
        if (d > d_end) break;
        float dmin;
        float phi = iso_sum(eye + dir * d, true, dmin);
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
                    a = max(a - pc.params.z / len, near);
                    float unused;
                    fa = iso_sum(eye + dir * a, true, unused);
                }
                if (fa >= threshold) { result = a; break; }
            }
            for (uint j = 0u; j < pc.steps.y; ++j) {
                float m = 0.5 * (a + b);
                float unused;
                float fm = iso_sum(eye + dir * m, true, unused);
                if (fm >= threshold) { b = m; fb = fm; } else { a = m; fa = fm; }
            }
            result = a + (b - a) * clamp((threshold - fa) / max(fb - fa, 1e-12), 0.0, 1.0);
            break;
        }
        prev = d;
        phi_prev = phi;
        d += max(dmin - pc.params.w, pc.params.z) / len;
    }
    imageStore(depth, p, vec4(result));
}
