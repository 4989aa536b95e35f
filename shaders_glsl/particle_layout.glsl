//! particle_layout.glsl — where everything lives in the renderer's particle buffer (vec4 indices): the shaders'
//! side of `ParticleLayout` (src/particles.rs), the one definition of it. `count` fluid positions (xyz, w: radius
//! and isolated mark), then `count` motions (x: id bits, y: how fast the velocity changes; read by `noise`), then —
//! when a GPU producer writes the diffuse particles — one header vec4 (the `diffuse` pass's indirect dispatch:
//! groups, 1, 1, particles drawn), then the diffuse particles, two vec4 each (read by `diffuse`).

// PARTICLE_VEC4S and DIFFUSE_VEC4S come from src/shader_constants.rs, like every constant.
uint particle_motion(uint count, uint i) { return count + i; }
uint particle_diffuse_header(uint count) { return PARTICLE_VEC4S * count; }
uint particle_diffuse(uint count, bool header, uint i) {
    return PARTICLE_VEC4S * count + (header ? 1u : 0u) + DIFFUSE_VEC4S * i;
}
