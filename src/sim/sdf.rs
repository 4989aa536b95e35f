//! A triangle mesh as a collider (`meniscus sim --collider FILE.obj`, and the demo's `--background-obj` under
//! `--sim`): its signed distance, sampled on a node lattice once on the CPU, uploaded, and read trilinearly by
//! the solver's collision projection (sim_common.glsl's `sdf_push`, mirrored by [`Sdf::sample`] and [`push_out`]). A particle whose
//! centre is closer than its radius to the surface (or inside) is moved along the field's gradient to distance r —
//! the usual signed-distance collision of particle solvers (e.g. FleX's SDF shapes).
//!
//! Built by hand because it is small and the product: distances within a band around the surface are exact
//! point–triangle distances (Ericson, Real-Time Collision Detection §5.1.5); the sign comes from crossing
//! parity along +x for every lattice row (rows offset by an irrational fraction of a cell, so no row grazes an
//! edge of an axis-aligned mesh). Closed (watertight) meshes get inside and outside; a row with an odd number of
//! crossings (an open mesh) is treated as outside along its whole length, so open meshes still push particles
//! off their front faces within the band.

use glam::{UVec3, Vec3};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::scene::geometry::Geometry;

/// Most lattice nodes (64 MiB of f32).
pub const MAX_NODES: usize = 16 << 20;

/// A signed distance field on a node lattice: value (i, j, k) at `origin + (i, j, k)·cell`, x fastest.
#[derive(Clone)]
pub struct Sdf {
    /// The lattice's first node.
    pub origin: Vec3,
    /// Node spacing.
    pub cell: f32,
    /// Nodes per axis.
    pub dims: UVec3,
    /// Signed distances (negative inside), clamped to ± `band`.
    pub values: Vec<f32>,
    /// Distance beyond which values are clamped.
    pub band: f32,
}

impl std::fmt::Debug for Sdf {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "Sdf {{ origin: {:?}, cell: {}, dims: {:?}, band: {} }}",
            self.origin, self.cell, self.dims, self.band
        )
    }
}

impl Sdf {
    /// One line for logs: the lattice's size and spacing.
    pub fn describe(&self) -> String {
        format!("distance lattice {}×{}×{} at {:.4} m", self.dims.x, self.dims.y, self.dims.z, self.cell)
    }
}

/// Closest point to `p` on triangle `t` (Ericson §5.1.5).
pub fn closest_on_triangle(p: Vec3, t: &[Vec3; 3]) -> Vec3 {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// Where the line {(x, y, z): x ∈ ℝ} crosses triangle `t`, if it does (strict edge tests).
fn cross_x(y: f32, z: f32, t: &[Vec3; 3]) -> Option<f32> {
    let e = |a: Vec3, b: Vec3| (b.y - a.y) * (z - a.z) - (b.z - a.z) * (y - a.y);
    let (w0, w1, w2) = (e(t[1], t[2]), e(t[2], t[0]), e(t[0], t[1]));
    let all_pos = w0 > 0.0 && w1 > 0.0 && w2 > 0.0;
    let all_neg = w0 < 0.0 && w1 < 0.0 && w2 < 0.0;
    if !(all_pos || all_neg) {
        return None;
    }
    let s = w0 + w1 + w2;
    Some((w0 * t[0].x + w1 * t[1].x + w2 * t[2].x) / s)
}

impl Sdf {
    /// The field of `mesh` with node spacing `cell` and exact distances up to `band`, over the mesh's bounds grown
    /// by `band` and clipped to `clip` (the container: nothing outside it is ever sampled).
    pub fn build(mesh: &Geometry, cell: f32, band: f32, clip: (Vec3, Vec3)) -> Result<Sdf> {
        if !(cell > 0.0 && band > 0.0) {
            return Err(Error::Invalid("a mesh collider needs a positive cell and band".into()));
        }
        let (lo, hi) = mesh.bounds();
        let lo = (lo - band).max(clip.0 - band);
        let hi = (hi + band).min(clip.1 + band);
        if hi.cmple(lo).any() {
            return Err(Error::Invalid("the collider mesh lies outside the container".into()));
        }
        let dims = (((hi - lo) / cell).ceil().as_uvec3() + 1).max(UVec3::splat(2));
        let nodes = dims.x as usize * dims.y as usize * dims.z as usize;
        if nodes > MAX_NODES {
            return Err(Error::Limit(format!(
                "the collider's distance field would need {nodes} nodes at {cell} m (at most {MAX_NODES})"
            )));
        }
        let origin = lo;
        let (nx, ny) = (dims.x as usize, dims.y as usize);
        let tris = &mesh.triangles;
        let bounds: Vec<(Vec3, Vec3)> =
            tris.iter().map(|t| (t[0].min(t[1]).min(t[2]) - band, t[0].max(t[1]).max(t[2]) + band)).collect();
        // Irrational offsets: no row passes exactly through an edge or vertex of an axis-aligned mesh.
        let (oy, oz) = (cell * 0.000_314_159_27, cell * 0.000_271_828_18);
        // The triangles near each z slab (bounds grown by the band), bucketed once: O(triangles × slabs they span).
        let nz = dims.z as usize;
        let mut near_slab: Vec<Vec<u32>> = vec![vec![]; nz];
        for (t, (b0, b1)) in bounds.iter().enumerate() {
            let k0 = ((b0.z - origin.z) / cell).ceil().max(0.0) as usize;
            let k1 = (((b1.z - origin.z) / cell).floor().max(-1.0) as i64).min(nz as i64 - 1);
            for slab in near_slab.iter_mut().take((k1 + 1).max(0) as usize).skip(k0) {
                slab.push(t as u32);
            }
        }
        let mut values = vec![band; nodes];
        values.par_chunks_mut(nx * ny).enumerate().for_each(|(k, slab)| {
            let z = origin.z + k as f32 * cell;
            let near = &near_slab[k];
            for j in 0..ny {
                let y = origin.y + j as f32 * cell;
                let row = &mut slab[j * nx..(j + 1) * nx];
                for t in near.iter().map(|&t| t as usize).filter(|&t| bounds[t].0.y <= y && y <= bounds[t].1.y) {
                    let (b0, b1) = bounds[t];
                    let i0 = (((b0.x - origin.x) / cell).floor().max(0.0) as usize).min(nx - 1);
                    let i1 = (((b1.x - origin.x) / cell).ceil().max(0.0) as usize).min(nx - 1);
                    for (i, v) in row.iter_mut().enumerate().take(i1 + 1).skip(i0) {
                        let p = Vec3::new(origin.x + i as f32 * cell, y, z);
                        let d = (closest_on_triangle(p, &tris[t]) - p).length();
                        if d < *v {
                            *v = d;
                        }
                    }
                }
                // The sign: crossings of this row (slightly offset) with every triangle spanning it.
                let (ry, rz) = (y + oy, z + oz);
                // (Every triangle spanning the row is in this slab's list: its bounds grown by the band hold rz.)
                let mut xs: Vec<f32> = near
                    .iter()
                    .map(|&t| &tris[t as usize])
                    .filter(|t| {
                        let (a, b) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
                        a.y <= ry && ry <= b.y && a.z <= rz && rz <= b.z
                    })
                    .filter_map(|t| cross_x(ry, rz, t))
                    .collect();
                if xs.is_empty() || xs.len() % 2 == 1 {
                    continue;
                }
                xs.sort_by(f32::total_cmp);
                let mut c = 0;
                for (i, v) in row.iter_mut().enumerate() {
                    let x = origin.x + i as f32 * cell;
                    while c < xs.len() && xs[c] <= x {
                        c += 1;
                    }
                    if c % 2 == 1 {
                        *v = -*v;
                    }
                }
            }
        });
        Ok(Sdf { origin, cell, dims, values, band })
    }

    /// The field of `mesh` for particles of radius `r` in the container `clip`: nodes a radius apart (coarser when
    /// that would pass [`MAX_NODES`]), exact within a band of 4 cells + r.
    pub fn for_particles(mesh: &Geometry, r: f32, clip: (Vec3, Vec3)) -> Result<Sdf> {
        let (lo, hi) = mesh.bounds();
        let extent = (hi.min(clip.1) - lo.max(clip.0)).max(Vec3::splat(r)) + 10.0 * r;
        let fit = (extent.x * extent.y * extent.z / (MAX_NODES as f32 * 0.9)).cbrt();
        let cell = r.max(fit);
        Sdf::build(mesh, cell, 4.0 * cell + r, clip)
    }

    /// The field and its gradient at `x` (trilinear; sim_common.glsl's `sdf_push` does the same arithmetic);
    /// outside the lattice, `band` and no gradient.
    pub fn sample(&self, x: Vec3) -> (f32, Vec3) {
        let g = (x - self.origin) / self.cell;
        let top = (self.dims - 1).as_vec3();
        if g.cmplt(Vec3::ZERO).any() || g.cmpge(top).any() {
            return (self.band, Vec3::ZERO);
        }
        let i = g.floor();
        let f = g - i;
        let i = i.as_uvec3();
        let (nx, ny) = (self.dims.x, self.dims.y);
        let at = |a: u32, b: u32, c: u32| self.values[(a + nx * (b + ny * c)) as usize];
        let mut c = [[[0f32; 2]; 2]; 2];
        for (dz, cz) in c.iter_mut().enumerate() {
            for (dy, cy) in cz.iter_mut().enumerate() {
                for (dx, v) in cy.iter_mut().enumerate() {
                    *v = at(i.x + dx as u32, i.y + dy as u32, i.z + dz as u32);
                }
            }
        }
        trilinear(&c, f, self.cell)
    }
}

/// Trilinear value and gradient of the 8 corners c[z][y][x] at fraction f, for spacing `cell`.
pub fn trilinear(c: &[[[f32; 2]; 2]; 2], f: Vec3, cell: f32) -> (f32, Vec3) {
    let lx = |z: usize, y: usize| c[z][y][0] + f.x * (c[z][y][1] - c[z][y][0]);
    let (x00, x10, x01, x11) = (lx(0, 0), lx(0, 1), lx(1, 0), lx(1, 1));
    let y0 = x00 + f.y * (x10 - x00);
    let y1 = x01 + f.y * (x11 - x01);
    let v = y0 + f.z * (y1 - y0);
    let dx = |z: usize, y: usize| c[z][y][1] - c[z][y][0];
    let gx0 = dx(0, 0) + f.y * (dx(0, 1) - dx(0, 0));
    let gx1 = dx(1, 0) + f.y * (dx(1, 1) - dx(1, 0));
    let gx = gx0 + f.z * (gx1 - gx0);
    let gy = (x10 - x00) + f.z * ((x11 - x01) - (x10 - x00));
    let gz = y1 - y0;
    (v, Vec3::new(gx, gy, gz) / cell)
}

/// Move `x` out to distance `r` from the surface along the gradient when it is closer (sim_common.glsl's
/// collision with the mesh).
pub fn push_out(sdf: &Sdf, x: Vec3, r: f32) -> Vec3 {
    let (d, g) = sdf.sample(x);
    let l = g.length();
    if d < r && l > 1e-6 {
        x + (r - d) * (g / l)
    } else {
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn box_sdf(p: Vec3, lo: Vec3, hi: Vec3) -> f32 {
        let (c, e) = ((lo + hi) * 0.5, (hi - lo) * 0.5);
        let q = (p - c).abs() - e;
        q.max(Vec3::ZERO).length() + q.max_element().min(0.0)
    }

    #[test]
    fn a_box_mesh_gives_the_box_distance() {
        let (lo, hi) = (Vec3::new(-0.2, 0.1, -0.15), Vec3::new(0.25, 0.4, 0.1));
        let cell = 0.02;
        let band = 0.1;
        let sdf = Sdf::build(&Geometry::cuboid(lo, hi), cell, band, (Vec3::splat(-1.0), Vec3::splat(1.0))).unwrap();
        // Every node: the exact distance within the band, clamped beyond, the right sign everywhere.
        let mut worst = 0f32;
        for k in 0..sdf.dims.z {
            for j in 0..sdf.dims.y {
                for i in 0..sdf.dims.x {
                    let p = sdf.origin + UVec3::new(i, j, k).as_vec3() * cell;
                    let want = box_sdf(p, lo, hi).clamp(-band, band);
                    let got = sdf.values[(i + sdf.dims.x * (j + sdf.dims.y * k)) as usize];
                    worst = worst.max((got - want).abs());
                }
            }
        }
        assert!(worst < 1e-5, "node distances off by {worst}");
        // Between nodes: trilinear, so within a cell's diagonal of the truth near edges, and the gradient points
        // out of the nearest face on the faces' middles.
        let (d, g) = sdf.sample(Vec3::new(0.03, 0.4 + 0.013, -0.02));
        assert!((d - 0.013).abs() < 1e-4, "above the top face: {d}");
        assert!((g - Vec3::Y).length() < 1e-3, "gradient {g}");
        let (d, g) = sdf.sample(Vec3::new(-0.2 + 0.007, 0.25, 0.0));
        assert!((d + 0.007).abs() < 1e-4, "inside the left face: {d}");
        assert!((g + Vec3::X).length() < 1e-3, "gradient {g}");
        // Pushed out to r along the normal.
        let x = push_out(&sdf, Vec3::new(0.03, 0.4 - 0.005, -0.02), 0.01);
        assert!((x - Vec3::new(0.03, 0.41, -0.02)).length() < 1e-4, "pushed to {x}");
        // Outside the lattice: nothing.
        assert_eq!(sdf.sample(Vec3::splat(0.9)), (band, Vec3::ZERO));
    }

    #[test]
    fn an_open_mesh_has_no_inside() {
        let quad = Geometry {
            triangles: vec![
                [Vec3::new(-0.1, 0.0, -0.1), Vec3::new(0.1, 0.0, -0.1), Vec3::new(0.1, 0.0, 0.1)],
                [Vec3::new(-0.1, 0.0, -0.1), Vec3::new(0.1, 0.0, 0.1), Vec3::new(-0.1, 0.0, 0.1)],
            ],
        };
        let sdf = Sdf::build(&quad, 0.02, 0.06, (Vec3::splat(-1.0), Vec3::splat(1.0))).unwrap();
        assert!(sdf.values.iter().all(|v| *v >= 0.0), "an open quad made negative distances");
        let (d, _) = sdf.sample(Vec3::new(0.01, 0.03, 0.01));
        assert!((d - 0.03).abs() < 1e-4, "{d}");
    }

    #[test]
    fn a_mesh_outside_the_container_or_too_fine_is_an_error() {
        let m = Geometry::cuboid(Vec3::splat(5.0), Vec3::splat(6.0));
        assert!(Sdf::build(&m, 0.02, 0.1, (Vec3::splat(-1.0), Vec3::splat(1.0))).is_err());
        let m = Geometry::cuboid(Vec3::splat(-1.0), Vec3::splat(1.0));
        assert!(matches!(Sdf::build(&m, 1e-4, 0.1, (Vec3::splat(-1.0), Vec3::splat(1.0))), Err(Error::Limit(_))));
    }
}
