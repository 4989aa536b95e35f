//! Compute primitives shared beyond the frame: THE neighbour grid (`grid`: a counting sort of points into cells
//! on the GPU, used by the `iso` surface, the simulation and the marching cubes), the GPU marching cubes (`mc`:
//! `meniscus mesh --gpu`, the Python package), the meshes' Laplacian smoothing and normals (`smooth`) and the
//! compute clear of 32-bit storage images (`clear`: the
//! passes' accumulators and depth images). Below the passes, the surfaces and the simulation, which all use
//! them; they use only `gpu`, `field` and the shaders.

pub mod clear;
pub mod grid;
pub mod mc;
pub mod smooth;
