#version 460
//! iso_aniso_rest — iso_rest.comp (the queued rays' second dispatch) over the anisotropic kernels' field (binding
//! 7, the `anisotropy` pass; Yu & Turk 2013), as iso_aniso.comp is iso.comp's.
// The work counters' subgroup sums (work_count.glsl).
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "common.glsl"
#define ISO_CELL_EMPTY
#define ISO_ANISO_BINDING 7
#include "iso_field.glsl"
#define ISO_REST
#include "iso_cast.glsl"
