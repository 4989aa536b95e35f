#version 460
//! iso_blocks — the `iso` pass's first dispatch with coarse-to-fine on (iso_cast.glsl; iso.comp otherwise): one
//! invocation per 2×2 block marches the block's even pixel, and its other pixels wherever their particles are
//! too small on screen for iso_fine.comp; unfinished rays are queued for iso_rest.comp as in iso.comp.
//! In/out: depth. In: back, the grid. Out: the queue (bindings 5, 6).
// The work counters' subgroup sums (work_count.glsl).
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "common.glsl"
#define ISO_CELL_EMPTY
#include "iso_field.glsl"
#define ISO_BLOCKS
#include "iso_cast.glsl"
