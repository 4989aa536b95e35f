#version 460
//! mesh_raster (fragment) — the live mesh surface's depth: the linear eye depth of the nearest triangle at the
//! pixel centre (perspective-correct interpolation of d = w is exact), into the R32F fluid depth. Early fragment
//! tests: the reversed-Z depth test (GREATER) rejects hidden fragments before this runs. See mesh_raster.vert.
layout(early_fragment_tests) in;
layout(location = 0) in float v_depth;
layout(location = 0) out float out_depth;

void main() { out_depth = v_depth; }
