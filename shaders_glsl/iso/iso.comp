#version 460
//! iso — ray-casts the SPH colour-field iso-surface φ = threshold per pixel (direct ray casting of the
//! field as in Fraedrich et al. 2010; the field is splashsurf's, see iso_field.glsl and src/field/iso/mod.rs for the
//! CPU reference). The march starts at the depth the `splat` pass wrote for spheres of the bound radius (the
//! surface lies inside them), steps by max(nearest point − bound, smallest step) so empty space is skipped,
//! and refines the first step past the threshold by bisection. Rays that leave the grid's box miss.
//! The march ends where the ray leaves the grid's box or behind the farthest bound sphere exit of the pixel
//! (pc.steps.z = 1, `back` from the splat) or of its 8×8 tile (2, from `splat_cull`, when the splat culls). The bracket is refined by bisection, then by one linear interpolation.
//! In/out: depth (R32F, linear eye depth; +inf = no fluid), rewritten in place per pixel. In: back (R32F, per pixel or per 8×8 tile).
//! Out: the queue of rays unfinished after pc.steps.w samples (bindings 5, 6), which iso_rest.comp finishes; the
//! field samples every dispatch took (binding 7: iso_cast.glsl's iso_work, bench's `iso_work.samples`).
//! The march is in iso_cast.glsl; iso_aniso.comp is the same march over the anisotropic kernels' field.
// The work counters' subgroup sums (work_count.glsl).
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "common.glsl"
#define ISO_CELL_EMPTY
#include "iso_field.glsl"
#include "iso_cast.glsl"
