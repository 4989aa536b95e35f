//! One uniform neighbour grid for the CPU-side statistics (spacing, number-density radius estimate, spray
//! neighbour counts): particles hashed into cubic cells of a chosen size, queried by the 27 cells around a point.
//! Positions that are not finite are left out of the grid (and find no neighbours).

use std::collections::HashMap;

use glam::Vec3;

/// Particles sorted into cubic cells of side `cell`.
pub struct UniformGrid<'a> {
    pos: &'a [[f32; 3]],
    cell: f32,
    cells: HashMap<[i64; 3], Vec<u32>>,
}

impl<'a> UniformGrid<'a> {
    /// Hash every finite position into cells of side `cell` (clamped to a tiny positive size).
    pub fn new(pos: &'a [[f32; 3]], cell: f32) -> Self {
        let cell = if cell.is_finite() { cell.max(1e-9) } else { 1.0 };
        let mut cells: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
        for (i, p) in pos.iter().enumerate() {
            if p.iter().all(|c| c.is_finite()) {
                cells.entry(Self::key_of(p, cell)).or_default().push(i as u32);
            }
        }
        UniformGrid { pos, cell, cells }
    }

    fn key_of(p: &[f32; 3], cell: f32) -> [i64; 3] {
        [(p[0] / cell).floor() as i64, (p[1] / cell).floor() as i64, (p[2] / cell).floor() as i64]
    }

    /// Calls `f(j, distance)` for every particle `j` within `h` of `p` (`h` ≤ the cell size), `p` itself included
    /// when it is one of the particles.
    pub fn for_each_within(&self, p: [f32; 3], h: f32, mut f: impl FnMut(usize, f32)) {
        if !p.iter().all(|c| c.is_finite()) {
            return;
        }
        debug_assert!(h <= self.cell * 1.0001, "query radius {h} exceeds the cell size {}", self.cell);
        let k = Self::key_of(&p, self.cell);
        let q = Vec3::from(p);
        let h2 = h * h;
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    if let Some(v) = self.cells.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) {
                        for &j in v {
                            let d2 = (Vec3::from(self.pos[j as usize]) - q).length_squared();
                            if d2 <= h2 {
                                f(j as usize, d2.sqrt());
                            }
                        }
                    }
                }
            }
        }
    }
}

/// Indices of up to `max` particles spread evenly over the set (every k-th).
pub fn sample_indices(n: usize, max: usize) -> impl Iterator<Item = usize> {
    (0..n).step_by((n / max.max(1)).max(1))
}
