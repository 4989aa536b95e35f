//! sphere.glsl — exact ray–sphere coverage of one particle, shared by `splat` and `thickness`.
//! Instead of a flat impostor with the fixed normal n = (u, v, sqrt(1−u²−v²)) (Moritz eq. 3.2–3.4) each pixel's
//! view ray is intersected with the sphere exactly (after FleX and blub), in a
//! numerically stable form (closest approach first: no cancellation of |c|² against r²).

/// Pixel bounds [lo, hi] of the sphere (view-space centre c, radius r) in an image of `size` with focal F;
/// the full image when the sphere crosses the near plane. Returns false when nothing can be covered.
bool sphere_bounds(vec3 c, float r, vec2 size, float F, float near, out ivec2 lo, out ivec2 hi) {
    float cd = -c.z;
    if (cd + r <= near) return false;
    if (cd - r <= near) {
        lo = ivec2(0);
        hi = ivec2(size) - 1;
        return true;
    }
    float d0 = cd - r, d1 = cd + r;
    float xmin = min((c.x - r) / d0, (c.x - r) / d1), xmax = max((c.x + r) / d0, (c.x + r) / d1);
    float ymin = min((c.y - r) / d0, (c.y - r) / d1), ymax = max((c.y + r) / d0, (c.y + r) / d1);
    vec2 h = 0.5 * size;
    // Pixel x is covered when its centre x + 0.5 lies inside the projected interval.
    lo = ivec2(ceil(h.x + F * xmin - 0.5), ceil(h.y - F * ymax - 0.5));
    hi = ivec2(floor(h.x + F * xmax - 0.5), floor(h.y - F * ymin - 0.5));
    lo = max(lo, ivec2(0));
    hi = min(hi, ivec2(size) - 1);
    return all(lessThanEqual(lo, hi));
}

/// Entry and exit LINEAR EYE DEPTH of the ray with direction `dir` (z = −1) through the sphere; false on a miss.
bool ray_sphere(vec3 dir, vec3 c, float r, out float d_in, out float d_out) {
    float len = length(dir);
    vec3 u = dir / len;
    float tc = dot(u, c);
    vec3 q = c - tc * u;
    float h2 = r * r - dot(q, q);
    if (h2 < 0.0) return false;
    float h = sqrt(h2);
    // t along the unit ray; depth = t / len because dir has z = −1.
    d_in = (tc - h) / len;
    d_out = (tc + h) / len;
    return true;
}

/// Entry and exit LINEAR EYE DEPTH of the ray with direction `dir` (z = −1) through the ellipsoid
/// {x : |M (x − c)| ≤ rho} (view space, M symmetric): with x = d·dir the quadratic |d·M dir − M c|² = rho² is
/// solved from its closest approach, as `ray_sphere`; false on a miss. Yu & Turk 2013's kernels as impostors.
bool ray_ellipsoid(vec3 dir, vec3 c, mat3 m, float rho, out float d_in, out float d_out) {
    vec3 a = m * dir;
    vec3 b = m * c;
    float aa = dot(a, a);
    float dc = dot(a, b) / aa;
    vec3 q = dc * a - b;
    float h2 = rho * rho - dot(q, q);
    if (h2 < 0.0) return false;
    float h = sqrt(h2 / aa);
    d_in = dc - h;
    d_out = dc + h;
    return true;
}

/// An anisotropic kernel (three vec4 of the `anisotropy` pass: centre + det M, m00 m01 m02 m11, m12 m22) as the
/// view-space ellipsoid {x : |m (x − c)| ≤ rho} of the volume of the sphere of radius `r` it replaces
/// (rho = r ∛det M), and `bound`: a sphere around `c` holding it (its longest semi-axis, rho / M's smallest
/// eigenvalue, is at most rho · `stretch`). Shared by `splat` and `thickness`.
void load_ellipsoid(vec4 a0, vec4 a1, vec4 a2, float r, float stretch, out vec3 c, out mat3 m, out float rho,
                    out float bound) {
    mat3 mw = mat3(a1.x, a1.y, a1.z, a1.y, a1.w, a2.x, a1.z, a2.x, a2.y);
    // |M (x − c)| in view space: x_w − c_w = vᵀ (x_v − c_v), so M_v = M vᵀ (M's rows stay world-space).
    m = mw * transpose(mat3(frame.view));
    rho = r * pow(a0.w, 1.0 / 3.0);
    c = (frame.view * vec4(a0.xyz, 1.0)).xyz;
    bound = rho * stretch;
}

/// One particle as every per-particle shader reads it: the `w` encoding Renderer::set_particles_with writes
/// (w > 0: its own radius; w = 0: the frame's; w < 0: isolated, |w| its radius, or about 0 for the frame's).
struct Particle {
    vec3 c;      // view-space centre
    float r;     // radius × radius_scale
    bool isolated;  // low density: left out of the surface (NVIDIA patent US 8,947,430), still adds thickness
};

Particle load_particle(vec4 pr, float radius_scale) {
    Particle p;
    float own = abs(pr.w);
    p.r = (own > 1e-30 ? own : frame.fluid.x) * radius_scale;
    p.c = (frame.view * vec4(pr.xyz, 1.0)).xyz;
    p.isolated = pr.w < 0.0;
    return p;
}

/// The per-thread pixel budget (MAX_PIXELS_PER_PARTICLE, src/shader_constants.rs): a sphere covering more
/// pixels (it swallowed the camera) is skipped.
bool over_budget(ivec2 lo, ivec2 hi) {
    return uint(hi.x - lo.x + 1) * uint(hi.y - lo.y + 1) > uint(MAX_PIXELS_PER_PARTICLE);
}
