//! Image quality of a rendered water surface, in space and in time: what `meniscus quality` reports.
//!
//! Inputs are depth images (linear eye depth d = −z_view > 0 per pixel, +inf where nothing is covered, row 0 the
//! top row: what the renderer's smoothed depth holds and what `../shared/data/quality`'s splashsurf references
//! hold) and the renderer's view-space normals and colours. Outputs:
//!
//! - [`compare`]: a depth image against a reference surface's — silhouette IoU, |Δdepth| median and p90 in
//!   particle radii, and the angle between normals rebuilt from depth on both sides ([`normals_from_depth`], the
//!   way a screen-space renderer shades, so both carry the same finite-difference error);
//! - [`roughness`]: how far each normal leans from the mean of its eight neighbours (median and p90, degrees):
//!   where the surface crosses the particles' layers (water on a lattice) it shows a terrace, a step of the
//!   normal a smooth surface does not have;
//! - [`Flicker`]: how a sequence of frames changes from frame to frame — per-pixel colour (8-bit steps) and normal
//!   change where the water covers both frames, and the warping error of Lai et al. 2018 ("Learning Blind Video
//!   Temporal Consistency", ECCV) of the normals: their change after each pixel's surface point is moved back
//!   along the velocity of the particle nearest to it, occluded pixels left out.

use glam::Vec3;

use crate::scene::camera::Camera;
use crate::scene::grid::UniformGrid;
use crate::{Error, Result};

/// A depth image: linear eye depth per pixel, +inf (or any non-finite or ≤ 0 value) where nothing is covered.
#[derive(Clone, Debug)]
pub struct DepthImage {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Row-major, row 0 at the top.
    pub depth: Vec<f32>,
}

impl DepthImage {
    /// Whether pixel `i` is covered.
    pub fn covered(&self, i: usize) -> bool {
        let d = self.depth[i];
        d.is_finite() && d > 0.0
    }
}

/// Read a float32 or float64 `.npy` of shape (H, W) or (H, W, 1), little-endian, C order: a depth image.
pub fn read_depth_npy(path: &std::path::Path) -> Result<DepthImage> {
    let bytes = crate::input::read(path)?;
    let bad = |at: usize, why: &str| Error::Parse { path: path.to_path_buf(), offset: at as u64, reason: why.into() };
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err(bad(0, "not a NumPy .npy file (no \\x93NUMPY magic)"));
    }
    let (len, start) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        2 | 3 if bytes.len() >= 12 => (u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize, 12),
        v => return Err(bad(6, &format!("unsupported .npy version {v}"))),
    };
    let header = bytes.get(start..start + len).ok_or_else(|| bad(start, "header runs past the end of the file"))?;
    let header = std::str::from_utf8(header).map_err(|_| bad(start, "header is not text"))?;
    let size = if header.contains("'<f4'") {
        4
    } else if header.contains("'<f8'") {
        8
    } else {
        return Err(bad(start, "expected dtype '<f4' or '<f8' (little-endian float32 or float64)"));
    };
    if header.contains("'fortran_order': True") {
        return Err(bad(start, "Fortran order is not supported: save the array in C order"));
    }
    let shape = header
        .split("'shape':")
        .nth(1)
        .and_then(|s| s.split(')').next())
        .map(|s| s.trim().trim_start_matches('(').split(',').filter_map(|d| d.trim().parse::<usize>().ok()).collect())
        .unwrap_or_else(Vec::new);
    let (h, w) = match shape[..] {
        [h, w] | [h, w, 1] => (h, w),
        _ => return Err(bad(start, &format!("expected a (H, W) depth image, found shape {shape:?}"))),
    };
    let data = &bytes[start + len..];
    let n = h.checked_mul(w).filter(|n| n.checked_mul(size) == Some(data.len()));
    let Some(n) = n else {
        return Err(bad(start + len, &format!("{h}×{w} values of {size} bytes, but {} bytes of data", data.len())));
    };
    let depth = (0..n)
        .map(|i| {
            let b = &data[i * size..(i + 1) * size];
            if size == 4 {
                f32::from_le_bytes(b.try_into().expect("4 bytes"))
            } else {
                f64::from_le_bytes(b.try_into().expect("8 bytes")) as f32
            }
        })
        .collect();
    Ok(DepthImage { width: w, height: h, depth })
}

/// The depth image of a triangle mesh seen by `camera` at `width`×`height`: one ray per pixel centre through a
/// BVH (`scene::geometry`), linear eye depth of the nearest hit, +inf where the ray hits nothing. Used for
/// reference surfaces (splashsurf's meshes) and for meshes under test.
pub fn mesh_depth(mesh: &crate::scene::geometry::Geometry, camera: &Camera, width: usize, height: usize) -> DepthImage {
    use rayon::prelude::*;
    let bvh = crate::scene::geometry::GpuBvh::build(mesh);
    let view = camera.view();
    let to_world = view.inverse();
    let f = height as f32 / (2.0 * (camera.fovy_deg.to_radians() * 0.5).tan());
    let mut depth = vec![f32::INFINITY; width * height];
    depth.par_chunks_mut(width).enumerate().for_each(|(y, row)| {
        for (x, d) in row.iter_mut().enumerate() {
            let dir_view =
                Vec3::new((x as f32 + 0.5 - width as f32 / 2.0) / f, -(y as f32 + 0.5 - height as f32 / 2.0) / f, -1.0)
                    .normalize();
            let dir = to_world.transform_vector3(dir_view);
            if let Some(t) = bvh.intersect(camera.eye, dir) {
                let z = t * -dir_view.z;
                if z > camera.near {
                    *d = z;
                }
            }
        }
    });
    DepthImage { width, height, depth }
}

/// View-space normals rebuilt from depth (x right, y up, +z towards the viewer; zero where none): each covered
/// pixel's position P = d · ((x + ½ − W/2)/F, −(y + ½ − H/2)/F, −1), F = H / (2 tan(fovy/2)); along x and along y
/// the one-sided difference towards the covered neighbour with the smaller |depth change| (so silhouettes and
/// occlusion edges do not bend the normal); n = normalize(∂P/∂y × ∂P/∂x), turned to face the camera. A pixel
/// with no covered neighbour along x or along y has none.
pub fn normals_from_depth(img: &DepthImage, fovy_deg: f32) -> Vec<[f32; 3]> {
    let (w, h) = (img.width, img.height);
    let f = h as f32 / (2.0 * (fovy_deg.to_radians() * 0.5).tan());
    let pos = |x: usize, y: usize| {
        let d = img.depth[y * w + x];
        Vec3::new(d * (x as f32 + 0.5 - w as f32 / 2.0) / f, -d * (y as f32 + 0.5 - h as f32 / 2.0) / f, -d)
    };
    let mut out = vec![[0.0; 3]; w * h];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if !img.covered(i) {
                continue;
            }
            let d = img.depth[i];
            let p = pos(x, y);
            // The difference towards the neighbour (by offset) with the smaller depth change.
            let side = |fwd: Option<usize>, back: Option<usize>, at: &dyn Fn(usize) -> Vec3| -> Option<Vec3> {
                let f = fwd.filter(|&j| img.covered(j)).map(|j| (img.depth[j] - d).abs());
                let b = back.filter(|&j| img.covered(j)).map(|j| (img.depth[j] - d).abs());
                match (f, b) {
                    (Some(a), Some(c)) if a <= c => Some(at(fwd?) - p),
                    (Some(_), Some(_)) => Some(p - at(back?)),
                    (Some(_), None) => Some(at(fwd?) - p),
                    (None, Some(_)) => Some(p - at(back?)),
                    (None, None) => None,
                }
            };
            let dx = side((x + 1 < w).then_some(i + 1), (x > 0).then(|| i - 1), &|j| pos(j % w, j / w));
            let dy = side((y + 1 < h).then_some(i + w), (y > 0).then(|| i - w), &|j| pos(j % w, j / w));
            if let (Some(dx), Some(dy)) = (dx, dy) {
                let mut n = dy.cross(dx).normalize_or_zero();
                if n.dot(p) > 0.0 {
                    n = -n;
                }
                out[i] = n.to_array();
            }
        }
    }
    out
}

fn valid(n: &[f32; 3]) -> bool {
    n.iter().all(|c| c.is_finite()) && n != &[0.0; 3]
}

fn angle_deg(a: &[f32; 3], b: &[f32; 3]) -> f32 {
    let (a, b) = (Vec3::from_array(*a).normalize(), Vec3::from_array(*b).normalize());
    a.dot(b).clamp(-1.0, 1.0).acos().to_degrees()
}

/// The `q`-quantile (0…1) of `v` (`crate::timing::percentile`: sorted in place, linearly interpolated as
/// numpy's default); None when `v` is empty.
pub fn quantile(v: &mut [f64], q: f64) -> Option<f32> {
    (!v.is_empty()).then(|| crate::timing::percentile(v, q) as f32)
}

/// A depth image against a reference surface's.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Comparison {
    /// Covered in both ÷ covered in either.
    pub iou: f32,
    /// Median |Δdepth| over the pixels covered in both, in particle radii.
    pub depth_median_r: Option<f32>,
    /// 90th percentile of |Δdepth|, in particle radii.
    pub depth_p90_r: Option<f32>,
    /// Median angle between the normals rebuilt from depth on both sides, degrees.
    pub normal_median_deg: Option<f32>,
    /// 90th percentile of that angle, degrees.
    pub normal_p90_deg: Option<f32>,
    /// Pixels covered in the reference, and in the test image.
    pub covered: [usize; 2],
}

/// Compare `test` with `reference` (same size) seen with a vertical field of view of `fovy_deg`, depths in
/// units of `radius`.
pub fn compare(test: &DepthImage, reference: &DepthImage, fovy_deg: f32, radius: f32) -> Result<Comparison> {
    if (test.width, test.height) != (reference.width, reference.height) {
        return Err(Error::Invalid(format!(
            "the render is {}×{} but the reference {}×{}: render at the reference's size",
            test.width, test.height, reference.width, reference.height
        )));
    }
    let (nt, nr) = (normals_from_depth(test, fovy_deg), normals_from_depth(reference, fovy_deg));
    let (mut both, mut either, mut ct, mut cr) = (0usize, 0usize, 0usize, 0usize);
    let (mut dd, mut na): (Vec<f64>, Vec<f64>) = (vec![], vec![]);
    for i in 0..test.depth.len() {
        let (t, r) = (test.covered(i), reference.covered(i));
        ct += t as usize;
        cr += r as usize;
        either += (t || r) as usize;
        if t && r {
            both += 1;
            dd.push(((test.depth[i] - reference.depth[i]).abs() / radius) as f64);
            if valid(&nt[i]) && valid(&nr[i]) {
                na.push(angle_deg(&nt[i], &nr[i]) as f64);
            }
        }
    }
    Ok(Comparison {
        iou: if either == 0 { 1.0 } else { both as f32 / either as f32 },
        depth_median_r: quantile(&mut dd, 0.5),
        depth_p90_r: quantile(&mut dd, 0.9),
        normal_median_deg: quantile(&mut na, 0.5),
        normal_p90_deg: quantile(&mut na, 0.9),
        covered: [cr, ct],
    })
}

/// How far normals lean from their neighbourhood: per pixel whose normal and eight neighbours' are valid, the
/// angle between its normal and the normalised mean of the eight.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Roughness {
    /// Median angle, degrees.
    pub median_deg: f32,
    /// 90th percentile, degrees.
    pub p90_deg: f32,
    /// Pixels measured.
    pub pixels: usize,
}

/// [`Roughness`] of a `width`×`height` normal image (zero = no normal); None when no pixel qualifies.
pub fn roughness(normals: &[[f32; 3]], width: usize, height: usize) -> Option<Roughness> {
    let mut a = vec![];
    for y in 1..height.saturating_sub(1) {
        for x in 1..width.saturating_sub(1) {
            let i = y * width + x;
            if !valid(&normals[i]) {
                continue;
            }
            let mut mean = Vec3::ZERO;
            let mut all = true;
            for (dx, dy) in [(-1i64, -1i64), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)] {
                let j = (i as i64 + dy * width as i64 + dx) as usize;
                all &= valid(&normals[j]);
                mean += Vec3::from_array(normals[j]).normalize_or_zero();
            }
            if all && mean.length() > 1e-6 {
                a.push(angle_deg(&normals[i], &mean.to_array()) as f64);
            }
        }
    }
    let pixels = a.len();
    Some(Roughness { median_deg: quantile(&mut a, 0.5)?, p90_deg: quantile(&mut a, 0.9)?, pixels })
}

/// One rendered frame as [`Flicker`] reads it: its colour, depth and normals.
pub struct Picture<'a> {
    /// The final colour, RGBA8.
    pub colour: &'a image::RgbaImage,
    /// The water's depth (linear eye depth, +inf where none).
    pub depth: &'a DepthImage,
    /// View-space normals (zero where none).
    pub normals: &'a [[f32; 3]],
}

/// How a sequence of frames changes from one frame to the next, over the pixels the water covers in both.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Flicker {
    /// Frame pairs measured.
    pub pairs: usize,
    /// Mean |Δcolour| per channel (R, G, B), in 8-bit steps.
    pub colour_mean: f32,
    /// 99th percentile of a pixel's largest channel change, in 8-bit steps.
    pub colour_p99: f32,
    /// Mean angle between a pixel's normals in consecutive frames, degrees.
    pub normal_mean_deg: f32,
    /// 90th percentile of that angle, degrees.
    pub normal_p90_deg: f32,
    /// Warping error (Lai et al. 2018) of the surface's normals: the mean angle between a pixel's normal and the
    /// previous frame's normal where its surface point was, moved back by its nearest particle's velocity over
    /// one frame, degrees; None without velocities. (Normals, not colour: the water's colour is mostly the
    /// static scene refracted and reflected, which does not move with the particles.)
    pub warp_mean_deg: Option<f32>,
    /// Share of the water's pixels the warping error could use (not occluded, inside the previous frame).
    pub warp_coverage: Option<f32>,
    /// The simulation's own motion: the median distance a particle moves from one frame to the next, in
    /// particle radii (velocity × frame time); None without velocities.
    pub particle_step_median_r: Option<f32>,
}

/// The motion of a frame's surface: its particles' positions and velocities (world units per second), the
/// time between frames, the camera.
pub struct SurfaceMotion<'a> {
    /// Particle positions (world).
    pub positions: &'a [[f32; 3]],
    /// Particle velocities (world units per second).
    pub velocities: &'a [[f32; 3]],
    /// Seconds between the two frames.
    pub dt: f32,
    /// The camera both frames were rendered with.
    pub camera: &'a Camera,
    /// Particle radius: pixels whose warped depth disagrees by more than 2 radii are occluded.
    pub radius: f32,
}

/// Accumulates [`Flicker`] over consecutive frames.
#[derive(Default)]
pub struct FlickerMeter {
    colour_sum: f64,
    colour_n: u64,
    colour_max: Vec<f64>,
    normal: Vec<f64>,
    warp_sum: f64,
    warp_n: u64,
    warp_water: u64,
    warped: bool,
    pairs: usize,
    steps: Vec<f64>,
}

impl FlickerMeter {
    /// Add the change from `prev` to `next` (same size); with `motion` (of `next`'s particles) also its warping
    /// error.
    pub fn add(&mut self, prev: &Picture, next: &Picture, motion: Option<&SurfaceMotion>) {
        let (w, h) = (next.depth.width, next.depth.height);
        self.pairs += 1;
        for i in 0..w * h {
            if !(prev.depth.covered(i) && next.depth.covered(i)) {
                continue;
            }
            let (a, b) = (prev.colour.as_raw(), next.colour.as_raw());
            let mut largest = 0.0f32;
            for c in 0..3 {
                let d = (a[4 * i + c] as f32 - b[4 * i + c] as f32).abs();
                self.colour_sum += d as f64;
                largest = largest.max(d);
            }
            self.colour_n += 3;
            self.colour_max.push(largest as f64);
            if valid(&prev.normals[i]) && valid(&next.normals[i]) {
                self.normal.push(angle_deg(&prev.normals[i], &next.normals[i]) as f64);
            }
        }
        let Some(m) = motion else { return };
        self.warped = true;
        self.steps.extend(m.velocities.iter().map(|v| (Vec3::from_array(*v).length() * m.dt / m.radius) as f64));
        let view = m.camera.view();
        let to_world = view.inverse();
        let f = h as f32 / (2.0 * (m.camera.fovy_deg.to_radians() * 0.5).tan());
        let near = UniformGrid::new(m.positions, 2.0 * m.radius);
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                if !next.depth.covered(i) {
                    continue;
                }
                self.warp_water += 1;
                let d = next.depth.depth[i];
                let p_view = Vec3::new(
                    d * (x as f32 + 0.5 - w as f32 / 2.0) / f,
                    -d * (y as f32 + 0.5 - h as f32 / 2.0) / f,
                    -d,
                );
                let p = to_world.transform_point3(p_view);
                let Some((k, _)) = nearest(&near, p, 2.0 * m.radius) else { continue };
                let back = view.transform_point3(p - Vec3::from_array(m.velocities[k]) * m.dt);
                let db = -back.z;
                if db <= 0.0 {
                    continue;
                }
                let (px, py) = (w as f32 / 2.0 + f * back.x / db, h as f32 / 2.0 - f * back.y / db);
                if !(px >= 0.0 && py >= 0.0 && px < w as f32 && py < h as f32) {
                    continue;
                }
                let j = py as usize * w + px as usize;
                if !prev.depth.covered(j) || (prev.depth.depth[j] - db).abs() > 2.0 * m.radius {
                    continue;
                }
                // The surface's own signal, its normal, at the warped point (nearest pixel): the water's colour
                // is mostly the static scene refracted and reflected, which does not move with the particles.
                if valid(&prev.normals[j]) && valid(&next.normals[i]) {
                    self.warp_sum += angle_deg(&prev.normals[j], &next.normals[i]) as f64;
                    self.warp_n += 1;
                }
            }
        }
    }

    /// The figure so far.
    pub fn result(&mut self) -> Flicker {
        let mean = |s: f64, n: u64| if n == 0 { 0.0 } else { (s / n as f64) as f32 };
        Flicker {
            pairs: self.pairs,
            colour_mean: mean(self.colour_sum, self.colour_n),
            colour_p99: quantile(&mut self.colour_max, 0.99).unwrap_or(0.0),
            normal_mean_deg: if self.normal.is_empty() {
                0.0
            } else {
                (self.normal.iter().sum::<f64>() / self.normal.len() as f64) as f32
            },
            normal_p90_deg: quantile(&mut self.normal, 0.9).unwrap_or(0.0),
            warp_mean_deg: (self.warped && self.warp_n > 0).then(|| mean(self.warp_sum, self.warp_n)),
            warp_coverage: (self.warped && self.warp_water > 0).then(|| self.warp_n as f32 / self.warp_water as f32),
            particle_step_median_r: quantile(&mut self.steps, 0.5),
        }
    }
}

/// How a sequence's meshes move from one frame to the next, in particle radii: for (a sample of) each vertex of a
/// frame's mesh, the distance to the nearest vertex of the next frame's mesh — as it stands (`plain`), and after
/// moving it by its nearest particle's velocity over one frame (`warped`: what is left is the surface changing in
/// ways the flow does not explain). Distances are capped at [`MESH_REACH`] radii; the vertex spacing (about half
/// the cube size) bounds the resolution from below.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct MeshFlicker {
    /// Frame pairs measured.
    pub pairs: usize,
    /// Mean distance without moving the vertices, radii.
    pub plain_mean_r: f32,
    /// Its 90th percentile.
    pub plain_p90_r: f32,
    /// Mean distance after moving each vertex with the flow, radii; None without velocities.
    pub warped_mean_r: Option<f32>,
    /// Its 90th percentile.
    pub warped_p90_r: Option<f32>,
}

/// The distance cap of [`MeshFlicker`], particle radii.
pub const MESH_REACH: f32 = 4.0;

/// Vertices sampled per frame pair by [`MeshFlickerMeter`] (every k-th, evenly).
pub const MESH_SAMPLES: usize = 20_000;

/// A frame's particles as they move: positions, velocities (world units per second) and the seconds to the
/// next frame.
pub struct FrameMotion<'a> {
    /// Positions (world).
    pub positions: &'a [[f32; 3]],
    /// Velocities, one per position.
    pub velocities: &'a [[f32; 3]],
    /// Seconds between the frames.
    pub dt: f32,
}

/// Accumulates [`MeshFlicker`] over consecutive frames.
#[derive(Default)]
pub struct MeshFlickerMeter {
    plain: Vec<f64>,
    warped: Vec<f64>,
    pairs: usize,
    moved: bool,
}

impl MeshFlickerMeter {
    /// Add the change from the mesh vertices `prev` to `next`; with `motion` (the particles of `prev`'s frame:
    /// positions, velocities, seconds between the frames) also the warped distance. `radius`: the particles'.
    pub fn add(&mut self, prev: &[[f32; 3]], next: &[[f32; 3]], radius: f32, motion: Option<&FrameMotion>) {
        self.pairs += 1;
        let reach = MESH_REACH * radius;
        let targets = UniformGrid::new(next, reach);
        let near = motion.map(|m| UniformGrid::new(m.positions, 2.0 * radius));
        let dist = |q: Vec3| nearest(&targets, q, reach).map_or(MESH_REACH, |(_, d)| d / radius);
        let step = prev.len().div_ceil(MESH_SAMPLES).max(1);
        for v in prev.iter().step_by(step) {
            let v = Vec3::from_array(*v);
            self.plain.push(dist(v) as f64);
            if let (Some(m), Some(near)) = (motion, &near) {
                self.moved = true;
                let moved =
                    nearest(near, v, 2.0 * radius).map_or(v, |(k, _)| v + Vec3::from_array(m.velocities[k]) * m.dt);
                self.warped.push(dist(moved) as f64);
            }
        }
    }

    /// The figure so far.
    pub fn result(&mut self) -> MeshFlicker {
        let mean = |v: &[f64]| if v.is_empty() { 0.0 } else { (v.iter().sum::<f64>() / v.len() as f64) as f32 };
        MeshFlicker {
            pairs: self.pairs,
            plain_mean_r: mean(&self.plain),
            plain_p90_r: quantile(&mut self.plain, 0.9).unwrap_or(0.0),
            warped_mean_r: self.moved.then(|| mean(&self.warped)),
            warped_p90_r: if self.moved { quantile(&mut self.warped, 0.9) } else { None },
        }
    }
}

/// The input index of the point of `grid` nearest to `p` within `reach` (at most the grid's cell size), and
/// its distance.
fn nearest(grid: &UniformGrid, p: Vec3, reach: f32) -> Option<(usize, f32)> {
    let mut best: Option<(usize, f32)> = None;
    grid.for_each_within(p.to_array(), reach, |j, d| {
        if best.is_none_or(|(_, b)| d < b) {
            best = Some((j, d));
        }
    });
    best
}

#[cfg(test)]
mod tests;
