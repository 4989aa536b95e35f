//! grid.glsl — THE GPU neighbour grid (the `grid` pass, src/compute/grid.rs): points counting-sorted into a
//! dense uniform grid of cubic cells, x fastest. Cell of a point: floor((p − origin) / cell), clamped to the
//! grid, so points outside the box land in its border cells. Queries walk the 3×3×3 cells around a point with
//! `start[c]` (first sorted point of cell c) and `counts[c]`.
//! The same layout as the CPU grid (src/scene/grid.rs), which the tests hold this one to.

struct GridShape {
    vec4 origin_cell;   // xyz: corner of cell (0,0,0); w: cell side
    uvec4 dims;         // xyz: cells per axis; w: cells in all
};

ivec3 grid_cell(GridShape g, vec3 p) {
    ivec3 c = ivec3(floor((p - g.origin_cell.xyz) / g.origin_cell.w));
    return clamp(c, ivec3(0), ivec3(g.dims.xyz) - 1);
}

uint grid_index(GridShape g, ivec3 c) {
    return uint(c.x) + g.dims.x * (uint(c.y) + g.dims.y * uint(c.z));
}
