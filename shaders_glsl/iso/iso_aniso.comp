#version 460
//! iso_aniso — the `iso` pass's ray cast (iso.comp, iso_cast.glsl) with the anisotropic kernels of the
//! `anisotropy` pass (binding 7; Yu & Turk 2013): φ(x) = Σ_j det(M_j) W(|M_j (x − c_j)| / h) / n_j.
//! In/out: as iso.comp; in: the kernels (three vec4 per sorted point).
// The work counters' subgroup sums (work_count.glsl).
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "common.glsl"
#define ISO_CELL_EMPTY
#define ISO_ANISO_BINDING 7
#include "iso_field.glsl"
#include "iso_cast.glsl"
