//! Laplacian smoothing of an extracted mesh with feature weights — the finishing splashsurf's users apply to
//! remove the particle-scale bumps of the raw SPH surface (`--mesh-smoothing-iters`, `--mesh-smoothing-weights`;
//! the "smoothed reference" of issue #15 was made with 25 iterations and weights), written here from the
//! description of the method, so that `meniscus mesh` and `--surface mesh` can give the same kind of surface:
//!
//! * umbrella operator, Jacobi style: every iteration moves each vertex to (1 − w_i) v_i + w_i · mean of its
//!   edge neighbours (all computed from the previous iteration's positions);
//! * feature weights w_i (optional, else 1): each particle's distance-weighted neighbour count
//!   c_j = Σ_k (1 − |x_j − x_k|² / h²) over the other particles within the support h, interpolated to the vertex
//!   with the SPH kernel (Shepard-normalised: Σ_j V_j c_j W / Σ_j V_j W, V_j = 1/n_j), divided by
//!   `normalization` (splashsurf's default 13), clamped to 1 and passed through the smooth step 6x⁵ − 15x⁴ + 10x³ —
//!   vertices of isolated droplets (few neighbours) barely move, so smoothing does not shrink the spray away;
//! * normals afterwards: area-weighted face normals at the vertices (the field's gradient belongs to the
//!   unsmoothed surface).
//!
//! Not done (splashsurf's `--mesh-cleanup`): the decimation of marching-cubes "barnacle" configurations before
//! smoothing.

use glam::Vec3;
use rayon::prelude::*;

use crate::field::extract::TriMesh;
use crate::field::iso::{kernel, IsoGrid};

/// How to smooth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmoothParams {
    /// Laplacian iterations (0: none).
    pub iterations: u32,
    /// Feature weights from the particles' neighbour counts (else every vertex has weight 1).
    pub weights: bool,
    /// The neighbour count that gives full weight (splashsurf: 13).
    pub normalization: f32,
}

impl Default for SmoothParams {
    fn default() -> Self {
        SmoothParams { iterations: 25, weights: true, normalization: 13.0 }
    }
}

/// Every vertex's edge neighbours (sorted, unique), as offsets into one list: each triangle lists its other two
/// corners at each corner (a counting sort into per-vertex runs), then each short run is sorted and deduplicated.
pub fn vertex_neighbours(m: &TriMesh) -> (Vec<u32>, Vec<u32>) {
    let n = m.vertices.len();
    let mut start = vec![0usize; n + 1];
    for t in &m.triangles {
        for &v in t {
            start[v as usize + 1] += 2;
        }
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut raw = vec![0u32; start[n]];
    for t in &m.triangles {
        for k in 0..3 {
            let v = t[k] as usize;
            raw[fill[v]] = t[(k + 1) % 3];
            raw[fill[v] + 1] = t[(k + 2) % 3];
            fill[v] += 2;
        }
    }
    let mut offsets = vec![0u32; n + 1];
    let mut out = Vec::with_capacity(raw.len() / 2);
    for v in 0..n {
        let run = &mut raw[start[v]..start[v + 1]];
        run.sort_unstable();
        let first = out.len();
        for &x in run.iter() {
            if out.len() == first || out.last() != Some(&x) {
                out.push(x);
            }
        }
        offsets[v + 1] = out.len() as u32;
    }
    (offsets, out)
}

/// The feature weight of every vertex (see the module doc).
pub fn feature_weights(m: &TriMesh, grid: &IsoGrid, inv_n: &[f32], normalization: f32) -> Vec<f32> {
    let h = grid.support;
    let counts = grid.neighbour_weights();
    m.vertices
        .par_iter()
        .map(|v| {
            let x = Vec3::from(*v);
            let (mut num, mut den) = (0.0f32, 0.0f32);
            grid.for_each_near(x, |j, y| {
                let w = kernel(x.distance(y) / h) * inv_n[j];
                num += w * counts[j];
                den += w;
            });
            let c = if den > 0.0 { num / den } else { 0.0 };
            let t = (c / normalization.max(1e-6)).clamp(0.0, 1.0);
            t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
        })
        .collect()
}

/// Smooth `m` in place (positions, then area-weighted normals); `grid` and `inv_n` are the particles the mesh
/// was extracted from (for the feature weights).
pub fn smooth(m: &mut TriMesh, grid: &IsoGrid, inv_n: &[f32], p: &SmoothParams) {
    if p.iterations == 0 || m.vertices.is_empty() {
        return;
    }
    let (offsets, nbrs) = vertex_neighbours(m);
    let weights =
        if p.weights { feature_weights(m, grid, inv_n, p.normalization) } else { vec![1.0; m.vertices.len()] };
    let mut cur: Vec<Vec3> = m.vertices.iter().map(|v| Vec3::from(*v)).collect();
    let mut next = cur.clone();
    for _ in 0..p.iterations {
        next.par_iter_mut().enumerate().for_each(|(i, out)| {
            let ns = &nbrs[offsets[i] as usize..offsets[i + 1] as usize];
            if ns.is_empty() {
                *out = cur[i];
                return;
            }
            let mean = ns.iter().fold(Vec3::ZERO, |a, &j| a + cur[j as usize]) / ns.len() as f32;
            *out = cur[i] * (1.0 - weights[i]) + mean * weights[i];
        });
        std::mem::swap(&mut cur, &mut next);
    }
    m.vertices = cur.iter().map(|v| v.to_array()).collect();
    m.normals = area_weighted_normals(m);
}

/// Vertex normals: the sum of the adjacent faces' (counter-clockwise) cross products, normalised.
pub fn area_weighted_normals(m: &TriMesh) -> Vec<[f32; 3]> {
    let mut acc = vec![Vec3::ZERO; m.vertices.len()];
    for t in &m.triangles {
        let [a, b, c] = t.map(|i| Vec3::from(m.vertices[i as usize]));
        let n = (b - a).cross(c - a);
        for &i in t {
            acc[i as usize] += n;
        }
    }
    acc.iter().map(|n| n.normalize_or_zero().to_array()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::extract::{extract, ExtractParams};

    /// The neighbour lists equal a set-based count over the edges of every triangle.
    #[test]
    fn vertex_neighbours_are_the_edge_neighbours() {
        let one = IsoGrid::build(&[[0.0, 0.0, 0.0], [0.5, 0.0, 0.0]], 0.4);
        let m = extract(&one, &one.inv_density(), &ExtractParams::new(0.03, 0.6));
        let mut want = vec![std::collections::BTreeSet::new(); m.vertices.len()];
        for t in &m.triangles {
            for k in 0..3 {
                want[t[k] as usize].insert(t[(k + 1) % 3]);
                want[t[(k + 1) % 3] as usize].insert(t[k]);
            }
        }
        let (offsets, nbrs) = vertex_neighbours(&m);
        for (v, w) in want.iter().enumerate() {
            let got = &nbrs[offsets[v] as usize..offsets[v + 1] as usize];
            assert_eq!(got, w.iter().copied().collect::<Vec<_>>().as_slice(), "vertex {v}");
        }
    }

    /// A lone particle's sphere: with weights off it shrinks towards its centre and stays closed and round;
    /// with weights on (a lone particle has no neighbours) it does not move at all. A flat slab's top stays flat
    /// and in place, and its vertex normals point up.
    #[test]
    fn smoothing_keeps_droplets_and_flat_water() {
        let r = 0.1f32;
        let one = IsoGrid::build(&[[0.3, 0.2, 0.1]], 4.0 * r);
        let inv = one.inv_density();
        let raw = extract(&one, &inv, &ExtractParams::new(0.25 * r, 0.6));
        let c = Vec3::new(0.3, 0.2, 0.1);
        let radius = |m: &TriMesh| m.vertices.iter().map(|v| (Vec3::from(*v) - c).length()).collect::<Vec<_>>();
        let mut kept = raw.clone();
        smooth(&mut kept, &one, &inv, &SmoothParams::default());
        assert_eq!(kept.vertices, raw.vertices, "a lone particle's weights are 0: nothing moves");
        let mut shrunk = raw.clone();
        smooth(&mut shrunk, &one, &inv, &SmoothParams { weights: false, ..SmoothParams::default() });
        let (r0, r1) = (radius(&raw), radius(&shrunk));
        let mean = |v: &[f32]| v.iter().sum::<f32>() / v.len() as f32;
        assert!(mean(&r1) < mean(&r0), "unweighted smoothing shrinks a sphere");
        let spread = r1.iter().fold(0f32, |a, &x| a.max((x - mean(&r1)).abs()));
        assert!(spread < 0.1 * mean(&r1), "still round: radii within {spread}");
        assert_eq!(crate::field::extract::open_or_flipped_edges(&shrunk), 0);
        for (v, n) in shrunk.vertices.iter().zip(&shrunk.normals) {
            assert!(Vec3::from(*n).dot(Vec3::from(*v) - c) > 0.0, "normal points out");
        }
        // A slab 12 × 12 × 4 particles at spacing 2 r: the top's middle stays where it was and flat.
        let d = 2.0 * r;
        let mut pts = vec![];
        for i in 0..12 {
            for j in 0..4 {
                for k in 0..12 {
                    pts.push([i as f32 * d, j as f32 * d, k as f32 * d]);
                }
            }
        }
        let g = IsoGrid::build(&pts, 4.0 * r);
        let inv = g.inv_density();
        let raw = extract(&g, &inv, &ExtractParams::new(0.5 * r, 0.6));
        let mut m = raw.clone();
        smooth(&mut m, &g, &inv, &SmoothParams::default());
        let mid = |v: &[f32; 3]| (v[0] - 5.5 * d).abs() < 2.0 * d && (v[2] - 5.5 * d).abs() < 2.0 * d && v[1] > 3.0 * d;
        let tops: Vec<(Vec3, Vec3)> = m
            .vertices
            .iter()
            .zip(&raw.vertices)
            .filter(|(v, _)| mid(v))
            .map(|(v, w)| (Vec3::from(*v), Vec3::from(*w)))
            .collect();
        assert!(tops.len() > 20);
        for (v, w) in &tops {
            assert!((v.y - w.y).abs() < 0.05 * r, "the flat top moved by {}", v.y - w.y);
        }
        let normals_up = m.vertices.iter().zip(&m.normals).filter(|(v, _)| mid(v)).all(|(_, n)| n[1] > 0.99);
        assert!(normals_up, "the flat top's normals point up");
    }
}
