//! sim_common.glsl — Position Based Fluids (Macklin & Müller, SIGGRAPH 2013),
//! shared by the sim_* shaders (the stages of src/sim/stages.rs): the simulation's uniform block (mirrored by
//! `sim::SimUniforms`), the SPH kernels (poly6 for densities, spiky gradients), the colliders and the
//! neighbour loop over THE GPU grid (grid.glsl, cells one kernel radius wide).
//! Particles live in two arrays: State {x (w: id bits), v} and the predicted positions x*, both in grid order
//! after the `sim_reorder` stage.
#include "grid.glsl"
#include "particle_layout.glsl"

layout(std140, binding = 0) uniform Sim {
    GridShape grid;
    vec4 lo_dt;          // container interior shrunk by the particle radius (xyz); time step (w)
    vec4 hi_h;           // its upper corner (xyz); kernel radius h (w)
    vec4 gravity_mass;   // gravity (xyz); particle mass (w)
    vec4 solver;         // rest density ρ0; relaxation ε; s_corr k; 1 / W_poly6(Δq)
    vec4 visc;           // XSPH c; vorticity ε; particle radius; a step's weight in the low-passed |Δv|/Δt
    vec4 kern;           // h²; poly6 coefficient; spiky gradient coefficient; particle volume m/ρ0
    uvec4 counts;        // particles; colliders; neighbour-list stride (capacity); s_corr exponent n
    vec4 sdf_lo;         // the mesh collider's distance lattice (src/sim/sdf.rs): first node (xyz), spacing (w)
    uvec4 sdf_dims;      // its nodes per axis (xyz); w: 1 when there is a mesh collider
    vec4 wall;           // static friction μ_s of the container's faces (x); y: 1 with a dynamic body; zw unused
    vec4 colliders[2 * MAX_COLLIDERS]; // per collider: (a.xyz, kind), (b) — see collide()
    // The emitter's nozzle (sim::scene::Emitter::nozzle; SPlisHSPlasH's particles AnimatedByEmitter): centre (xyz)
    // and kind (w: 0 none, 1 box, 2 cylinder); its axes along the flow, up and across (xyz) with the half
    // extents (w; the cylinder's radius in the up one's); the velocity it moves its particles at (xyz).
    vec4 nozzle[5];
} sim;

// Whether a particle at x (its position at the step's start) is in the emitter's nozzle, which moves it at
// sim.nozzle[4] instead of the solve (sim_velocity, sim_viscosity).
bool in_nozzle(vec3 x) {
    float kind = sim.nozzle[0].w;
    if (kind == 0.0) return false;
    vec3 r = x - sim.nozzle[0].xyz;
    float a = dot(r, sim.nozzle[1].xyz), u = dot(r, sim.nozzle[2].xyz), c = dot(r, sim.nozzle[3].xyz);
    if (abs(a) > sim.nozzle[1].w) return false;
    if (kind == 1.0) return abs(u) <= sim.nozzle[2].w && abs(c) <= sim.nozzle[3].w;
    return u * u + c * c <= sim.nozzle[2].w * sim.nozzle[2].w;
}

struct State {
    vec4 x;   // position; w: the particle's id (uint bits)
    vec4 v;   // velocity; w: the low-passed change of velocity |Δv|/Δt (sim_viscosity)
};

// A State read through its RGBA32UI texel view (the stages that read the state: two texels per particle, so
// the id bits in x.w pass unchanged): x of particle i at texel 2i, v at 2i + 1.
vec4 state_x(usamplerBuffer s, uint i) { return uintBitsToFloat(texelFetch(s, int(2u * i))); }
vec4 state_v(usamplerBuffer s, uint i) { return uintBitsToFloat(texelFetch(s, int(2u * i + 1u))); }

// W_poly6 without its coefficient, (h² − r²)³ (0 beyond h), for loops that apply the coefficient once
// (sim_density).
float poly6_terms(float r2) {
    float d = max(sim.kern.x - r2, 0.0);
    return d * d * d;
}

// W_poly6 of a squared distance.
float poly6(float r2) {
    float d = max(sim.kern.x - r2, 0.0);
    return sim.kern.y * d * d * d;
}

// The spiky gradient is taken as zero below r² = SPIKY_R2_MIN h² (coincident particles have no direction).
const float SPIKY_R2_MIN = 1e-18;

// The spiky gradient without its coefficient, for loops that apply the coefficient once (sim_density,
// sim_solve): ∇W_spiky(r) / coefficient = (a2 · il) r with a2 = (h − |r|)² (0 beyond h and for coincident
// particles) and il = 1/|r|.
void spiky_terms(float r2, out float a2, out float il) {
    il = inversesqrt(max(r2, SPIKY_R2_MIN * sim.kern.x));
    float a = max(sim.hi_h.w - r2 * il, 0.0);
    a2 = r2 >= SPIKY_R2_MIN * sim.kern.x ? a * a : 0.0;
}

// ∇W_spiky at r = x_i − x_j (points from j to i, so it is negative along r).
vec3 spiky_grad(vec3 r) {
    float r2 = dot(r, r);
    float h = sim.hi_h.w;
    bool inside = r2 < sim.kern.x && r2 >= SPIKY_R2_MIN * sim.kern.x;
    float il = inversesqrt(max(r2, SPIKY_R2_MIN * sim.kern.x));
    float a = h - r2 * il;
    return inside ? (sim.kern.z * a * a * il) * r : vec3(0.0);
}

// The container's walls as a continuum of rest-density fluid beyond each face (boundary handling without
// boundary particles): a particle at distance y from a face misses the mass F(y) = ∫_y^h A(z) dz of the
// half-space behind it, with A(z) = ∫∫ W_poly6 over the plane at depth z = π K (h² − z²)⁴ / 4 (K: the poly6
// coefficient). Returns Σ F over the six faces (a fraction of ρ0) and, in grad, its gradient ∇_i (F/1) —
// pointing into the walls. Without it the particles at the walls are under-dense and stream along them.
float wall_f(float y, out float a) {
    float h = sim.hi_h.w;
    y = clamp(y, 0.0, h);
    float h2 = h * h;
    float q = h2 - y * y;
    float c = 0.25 * 3.14159265 * sim.kern.y;
    a = c * q * q * q * q;
    // Antiderivative of (h² − z²)⁴.
    float y2 = y * y;
    float gy = y * (h2 * h2 * h2 * h2 - 4.0 / 3.0 * h2 * h2 * h2 * y2 + 6.0 / 5.0 * h2 * h2 * y2 * y2
                    - 4.0 / 7.0 * h2 * y2 * y2 * y2 + y2 * y2 * y2 * y2 / 9.0);
    float gh = h * h2 * h2 * h2 * h2 * (1.0 - 4.0 / 3.0 + 6.0 / 5.0 - 4.0 / 7.0 + 1.0 / 9.0);
    return c * (gh - gy);
}

float wall_density(vec3 x, out vec3 grad) {
    // The container's faces: the interior bounds grown back by the particle radius.
    vec3 lo = sim.lo_dt.xyz - sim.visc.z;
    vec3 hi = sim.hi_h.xyz + sim.visc.z;
    float f = 0.0;
    grad = vec3(0.0);
    for (int k = 0; k < 3; ++k) {
        float a;
        f += wall_f(x[k] - lo[k], a);
        grad[k] -= a;
        f += wall_f(hi[k] - x[k], a);
        grad[k] += a;
    }
    return f;
}

#ifdef SIM_BODY_BINDING
// The dynamic rigid sphere (src/sim/scene.rs `Body`; DFSPH only, `sim.wall.y` = 1 when the scene has one): body[0]
// its centre and radius, [1] its velocity and mass, [2] its angular velocity, [3] restitution and friction against
// the container's faces, [4] and [5] the faces its centre's contacts keep it within (lo, hi); from
// body[BODY_HEAD] on, per particle (grid order, this step), the impulse the particle's corrections gave the body
// (sim_dfsph_update adds, sim_dfsph_alpha zeroes, sim_body sums).
layout(std430, binding = SIM_BODY_BINDING) buffer Body { vec4 body[]; };
const uint BODY_HEAD = 6u;

bool body_on() { return sim.wall.y > 0.5; }

// The body's surface as the container's walls are: rest-density fluid beyond it, the particle missing the mass
// F(d) at distance d = |x − c| − R of the surface (the plane's F, wall_f: the sphere's curvature neglected — its
// radius is ~6 kernel radii in the shipped scene, where the plane's share overestimates the missing mass by a few
// per cent), the gradient pointing into the body. SPlisHSPlasH's volume maps integrate the body's own shape.
float body_density(vec3 x, out vec3 grad) {
    grad = vec3(0.0);
    if (!body_on()) return 0.0;
    vec3 d = x - body[0].xyz;
    float l = length(d);
    float a;
    float f = wall_f(l - body[0].w, a);
    if (l > 1e-9) grad = -a * d / l;
    return f;
}

// The body's surface velocity along its normal: the centre's (a sphere's rotation moves its surface tangentially).
vec3 body_velocity() { return body[1].xyz; }
#endif

#ifdef SIM_SDF_BINDING
// The mesh collider (src/sim/sdf.rs, whose Sdf::sample and push_out do the same arithmetic): a signed distance
// on a node lattice, read trilinearly; a centre closer than r to the surface moves along the gradient to r.
layout(std430, binding = SIM_SDF_BINDING) readonly buffer SdfValues { float sdf[]; };
// Whether the scene has a mesh collider, a specialization constant (Stages::new): lavapipe runs a branch's body
// even when no lane takes it, so without it every particle paid the lattice's eight loads and the trilinear
// arithmetic in sim_predict and each sim_solve iteration (docs/simulation.md, commit 434fdd1).
layout(constant_id = 1) const bool SIM_MESH_COLLIDER = true;

float sdf_node(uvec3 i) { return sdf[i.x + sim.sdf_dims.x * (i.y + sim.sdf_dims.y * i.z)]; }

vec3 sdf_push(vec3 x, float r) {
    if (!SIM_MESH_COLLIDER || sim.sdf_dims.w == 0u) return x;
    float cell = sim.sdf_lo.w;
    vec3 g = (x - sim.sdf_lo.xyz) / cell;
    vec3 top = vec3(sim.sdf_dims.xyz - 1u);
    if (any(lessThan(g, vec3(0.0))) || any(greaterThanEqual(g, top))) return x;
    vec3 fl = floor(g);
    vec3 f = g - fl;
    uvec3 i = uvec3(fl);
    float c000 = sdf_node(i), c001 = sdf_node(i + uvec3(1, 0, 0));
    float c010 = sdf_node(i + uvec3(0, 1, 0)), c011 = sdf_node(i + uvec3(1, 1, 0));
    float c100 = sdf_node(i + uvec3(0, 0, 1)), c101 = sdf_node(i + uvec3(1, 0, 1));
    float c110 = sdf_node(i + uvec3(0, 1, 1)), c111 = sdf_node(i + uvec3(1, 1, 1));
    // cZYX: z, y, x offsets; the same order of operations as sdf.rs's trilinear().
    float x00 = c000 + f.x * (c001 - c000), x10 = c010 + f.x * (c011 - c010);
    float x01 = c100 + f.x * (c101 - c100), x11 = c110 + f.x * (c111 - c110);
    float y0 = x00 + f.y * (x10 - x00);
    float y1 = x01 + f.y * (x11 - x01);
    float d = y0 + f.z * (y1 - y0);
    float gx0 = (c001 - c000) + f.y * ((c011 - c010) - (c001 - c000));
    float gx1 = (c101 - c100) + f.y * ((c111 - c110) - (c101 - c100));
    vec3 grad = vec3(gx0 + f.z * (gx1 - gx0), (x10 - x00) + f.z * ((x11 - x01) - (x10 - x00)), y1 - y0) / cell;
    float l = length(grad);
    if (d < r && l > 1e-6) x += (r - d) * (grad / l);
    return x;
}
#endif

// Project a position out of every collider (and the mesh collider, where the stage binds it), then into the
// container.
//   kind 1: solid sphere, centre a.xyz, radius b.x;
//   kind 2: solid box, centre a.xyz, half extents b.xyz (left through the nearest face);
//   kind 3: half-space n·x ≥ b.x kept, n = a.xyz (unit).
vec3 collide(vec3 x) {
    float r = sim.visc.z;
    for (uint k = 0u; k < sim.counts.y; ++k) {
        vec4 a = sim.colliders[2u * k];
        vec4 b = sim.colliders[2u * k + 1u];
        uint kind = uint(a.w + 0.5);
        if (kind == COLLIDER_SPHERE) {
            vec3 d = x - a.xyz;
            float l = length(d);
            float R = b.x + r;
            if (l < R) x = a.xyz + (l > 1e-9 ? d / l : vec3(0.0, 1.0, 0.0)) * R;
        } else if (kind == COLLIDER_BOX) {
            vec3 d = x - a.xyz;
            vec3 e = b.xyz + r;
            vec3 q = e - abs(d);
            if (all(greaterThan(q, vec3(0.0)))) {
                vec3 s = vec3(d.x >= 0.0 ? 1.0 : -1.0, d.y >= 0.0 ? 1.0 : -1.0, d.z >= 0.0 ? 1.0 : -1.0);
                if (q.x <= q.y && q.x <= q.z) x.x = a.x + s.x * e.x;
                else if (q.y <= q.z) x.y = a.y + s.y * e.y;
                else x.z = a.z + s.z * e.z;
            }
        } else if (kind == COLLIDER_PLANE) {
            float s = dot(a.xyz, x) - (b.x + r);
            if (s < 0.0) x -= s * a.xyz;
        }
    }
#ifdef SIM_SDF_BINDING
    x = sdf_push(x, r);
#endif
    return clamp(x, sim.lo_dt.xyz, sim.hi_h.xyz);
}

// Over the sorted places [S, E) of the particles in each row of cells around p: the 27 cells around p as 9
// ranges, since cells are numbered x fastest and sorted in that order, so the three cells of a row (x − 1 …
// x + 1) are one contiguous range. Close with END_ROWS. Needs `counts` and `start` (the grid pass's outputs)
// declared by the shader as texel buffers (usamplerBuffer): as storage buffers, the two loads per row were two
// loops over the lanes each on lavapipe (docs/simulation.md, commit 961bada). Only sim_neighbours walks cells; the other
// stages read its neighbour lists.
#define FOR_ROWS(p, S, E)                                                                       \
    ivec3 c0_ = grid_cell(sim.grid, p);                                                        \
    ivec3 d_ = ivec3(sim.grid.dims.xyz);                                                       \
    int x0_ = max(c0_.x - 1, 0), x1_ = min(c0_.x + 1, d_.x - 1);                               \
    for (int z_ = max(c0_.z - 1, 0); z_ <= min(c0_.z + 1, d_.z - 1); ++z_)                    \
    for (int y_ = max(c0_.y - 1, 0); y_ <= min(c0_.y + 1, d_.y - 1); ++y_) {                   \
        uint S = texelFetch(start, int(grid_index(sim.grid, ivec3(x0_, y_, z_)))).x;            \
        int b_ = int(grid_index(sim.grid, ivec3(x1_, y_, z_)));                                \
        uint E = texelFetch(start, b_).x + texelFetch(counts, b_).x;
#define END_ROWS }

// VISIT(j) for each of particle i's neighbours j in list order (within h of it when the list was made, itself
// excluded), as listed by sim_neighbours at the step's predicted positions (Macklin & Müller, Alg. 1 line 6:
// the neighbour set is found once per step). VISIT is the name of a one-argument macro the stage defines,
// usually calling a function with its accumulators. On lavapipe a storage-buffer load whose index differs per
// lane is a loop over the 8 lanes, each with its branches (docs/simulation.md, commit a4c867b): the index loads, not the
// kernels, were most of a list stage's time (commit c680c5d). So the loads are made few:
// - compiled with NBR16 (the programs of a simulation of at most 65,536 particles), the lists hold 16-bit
//   indices, eight to a 16-byte texel (slots 8q … 8q + 7 of particle i in texel q × capacity + i, two to a word,
//   low half first), read with one branch-free texelFetch per eight neighbours; the last, partial texel's pairs
//   are picked from the fetched vector;
// - otherwise two 32-bit indices are loaded before either is visited (the pair halves the loop's own cost,
//   sim_density −13 %, commit a4c867b).
// The visits and their order are the same either way, so the sums are too. The lists are slot-major (slot k of
// every particle contiguous), so the threads of a warp read one run of memory, not one word per list. Needs
// `nbr_count` and `nbrs` declared (NEIGHBOUR_BUFFERS).
#ifdef NBR16
#define NBR_LO(p) ((p) & 0xffffu)
#define NBR_HI(p) ((p) >> 16u)
#define FOR_NEIGHBOURS(i, VISIT)                                                                \
    {                                                                                          \
        uint n_ = texelFetch(nbr_count, int(i)).x, k_ = 0u;                                    \
        for (; k_ + 8u <= n_; k_ += 8u) {                                                      \
            uvec4 q_ = texelFetch(nbrs, int((k_ >> 3u) * sim.counts.z + (i)));                 \
            VISIT(NBR_LO(q_.x)); VISIT(NBR_HI(q_.x));                                          \
            VISIT(NBR_LO(q_.y)); VISIT(NBR_HI(q_.y));                                          \
            VISIT(NBR_LO(q_.z)); VISIT(NBR_HI(q_.z));                                          \
            VISIT(NBR_LO(q_.w)); VISIT(NBR_HI(q_.w));                                          \
        }                                                                                      \
        if (k_ < n_) {                                                                         \
            uvec4 q_ = texelFetch(nbrs, int((k_ >> 3u) * sim.counts.z + (i)));                 \
            for (; k_ + 1u < n_; k_ += 2u) {                                                   \
                uint p_ = q_[(k_ >> 1u) & 3u];                                                 \
                VISIT(NBR_LO(p_));                                                             \
                VISIT(NBR_HI(p_));                                                             \
            }                                                                                  \
            if (k_ < n_) {                                                                     \
                uint c_ = NBR_LO(q_[(k_ >> 1u) & 3u]);                                         \
                VISIT(c_);                                                                     \
            }                                                                                  \
        }                                                                                      \
    }
// The neighbour-list bindings of the stages that read them (at 1 and 2).
#define NEIGHBOUR_BUFFERS                                                                       \
    layout(binding = 1) uniform usamplerBuffer nbr_count;                                      \
    layout(binding = 2) uniform usamplerBuffer nbrs;
#else
#define FOR_NEIGHBOURS(i, VISIT)                                                                \
    {                                                                                          \
        uint n_ = texelFetch(nbr_count, int(i)).x, k_ = 0u;                                    \
        for (; k_ + 1u < n_; k_ += 2u) {                                                       \
            uint a_ = nbrs[k_ * sim.counts.z + (i)];                                           \
            uint b_ = nbrs[(k_ + 1u) * sim.counts.z + (i)];                                    \
            VISIT(a_);                                                                         \
            VISIT(b_);                                                                         \
        }                                                                                      \
        if (k_ < n_) {                                                                         \
            uint c_ = nbrs[k_ * sim.counts.z + (i)];                                           \
            VISIT(c_);                                                                         \
        }                                                                                      \
    }
// The neighbour-list bindings of the stages that read them (at 1 and 2). 32-bit lists stay storage buffers: as
// texel buffers of one index each they measured no faster (docs/simulation.md, commit a4c867b), and a texel view of a list
// of more than 65,536 particles could pass the devices' texel-buffer limit (2^27 texels) at a few million.
#define NEIGHBOUR_BUFFERS                                                                       \
    layout(binding = 1) uniform usamplerBuffer nbr_count;                                      \
    layout(std430, binding = 2) readonly buffer Nbrs { uint nbrs[]; };
#endif

// The s_corr exponent n = 1..15, a specialization constant (Stages::new sets it from Params::scorr_n), so the
// bit tests below fold away: lavapipe runs both sides of a branch, so a `pow` beside the n = 4 case had cost
// sim_solve 23 %, and the same power by squaring on a uniform's n still about 10 % (docs/simulation.md, commit 434fdd1). The
// uniform block's counts.w carries n too, for the CPU reference.
layout(constant_id = 0) const uint SCORR_N = 4u;

// (s_corr ratio)ⁿ by squaring; for n = 4 exactly (x·x)·(x·x).
float scorr_pow(float x) {
    float p = (SCORR_N & 1u) != 0u ? x : 1.0;
    float b = x * x;
    p = (SCORR_N & 2u) != 0u ? p * b : p;
    b *= b;
    p = (SCORR_N & 4u) != 0u ? p * b : p;
    b *= b;
    p = (SCORR_N & 8u) != 0u ? p * b : p;
    return p;
}
