#version 460
//! iso_fine — the `iso` pass's coarse-to-fine dispatch (iso_cast.glsl, after iso.comp and iso_rest.comp): where
//! particles are large on screen the first dispatches marched only the pixels with even x and y; here every
//! other such pixel starts at its marched neighbours' mean depth and takes one Newton step of the field φ along
//! its ray (φ and ∇φ in one sum, iso_field.glsl's iso_sum_grad), or marches as iso.comp where that guess is not
//! trusted. Isotropic kernels only.
//! In/out: depth (the bound spheres' depth at this pixel, the surface at its marched neighbours; the surface
//! out). In: back, the grid.
// The work counters' subgroup sums (work_count.glsl).
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "common.glsl"
#define ISO_CELL_EMPTY
#include "iso_field.glsl"
#define ISO_FINE
#include "iso_cast.glsl"
