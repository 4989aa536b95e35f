#version 460
//! iso_vol — the `iso` pass's cast over the smoothed field (`[iso] smoothing` > 0): the same march as iso.comp
//! (iso_cast.glsl: from the bound spheres' depth, queued long rays finished by the ISO_REST variant), but each
//! sample is F = φ + w(c̄) (B − φ): B and c̄ read from the sparse lattice that `iso_volume` built once per set
//! of particles (a quadratic B-spline: C¹ across voxel faces, so the surface's normals do not crease there), w
//! the bulk weight, and the exact φ summed over the neighbours only where w < 1 (spray, sheets and the calm
//! water's rim keep their particle-scale shape). Where w = 0 the march skips empty space by the nearest point's
//! distance as iso.comp does; elsewhere it takes its smallest steps. CPU reference: VolumeShape::sample and
//! smoothed_field in src/field/iso/mod.rs.
//! In: the weighted points (binding 1), cells (2), back (4), the lattice's table (7) and sums (8, RG32UI).
//! In/out: depth (3). Out: the queue (5, 6). Variants: REST (the queued rays, a lane each), REST_WIDE8,
//! REST_WIDE8_MANY and REST_WIDE32 (8 or 32 lanes each, `[iso] rest_lanes`).
// The work counters' subgroup sums (work_count.glsl).
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#if defined(ISO_REST_WIDE8) || defined(ISO_REST_WIDE8_MANY) || defined(ISO_REST_WIDE32)
#extension GL_KHR_shader_subgroup_shuffle : require
#endif
#include "common.glsl"
#define ISO_CELL_EMPTY
#define ISO_VOLUME
#include "iso_field.glsl"
#include "iso_cast.glsl"
