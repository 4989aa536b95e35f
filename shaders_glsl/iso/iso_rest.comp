#version 460
//! iso_rest — the `iso` pass's second dispatch (iso_cast.glsl): finishes the rays that iso.comp queued after
//! its first pc.steps.w samples, one queue entry per invocation, dispatched indirectly from the queue header.
//! In: the queue (bindings 5, 6), the grid, back. Out: depth at the queued pixels. ISO_REST_WIDE8,
//! ISO_REST_WIDE8_MANY and ISO_REST_WIDE32 (`[iso] rest_lanes` 8 and 32): 8 or 32 lanes of a subgroup march each
//! ray together (iso_cast.glsl).
// The work counters' subgroup sums (work_count.glsl).
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#if defined(ISO_REST_WIDE8) || defined(ISO_REST_WIDE8_MANY) || defined(ISO_REST_WIDE32)
#extension GL_KHR_shader_subgroup_shuffle : require
#endif
#include "common.glsl"
#define ISO_CELL_EMPTY
#include "iso_field.glsl"
#define ISO_REST
#include "iso_cast.glsl"
