#version 460
//! iso_vol — the `iso` pass's cast over the smoothed field (`[iso] smoothing` > 0): the same march as iso.comp
//! (iso_cast.glsl: from the bound spheres' depth, queued long rays finished by the ISO_REST variant), but each
//! sample is a trilinear read of the lattice that `iso_volume` and `iso_blur` built once per set of particles
//! (iso_field.glsl with ISO_VOLUME: 8 texel fetches instead of a sum over ~200 neighbours). No nearest-point
//! distance: the march takes its smallest steps. CPU reference: VolumeShape::sample and march in src/surface/iso/field.rs.
//! In: the field (binding 1, R32F per voxel), back (3). In/out: depth (2). Out: the queue (4, 5).
#include "common.glsl"
#define ISO_VOLUME
#define ISO_CAST_BINDING 2
#include "iso_field.glsl"
#include "iso_cast.glsl"
