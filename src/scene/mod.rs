//! Particles and where they come from: built-in procedural scenes and loaders for simulator output.
//! Also the statistics the renderer needs: percentile bounds (robust to stray particles) and the particle
//! spacing, from which the radius is estimated when `--radius` is not given.

pub mod bgeo;
pub mod bytes;
pub mod camera;
pub mod csv;
pub mod format;
pub mod geometry;
pub mod grid;
pub mod ply;
pub mod procedural;
pub mod realflow;
pub mod sequence;
pub mod sky;
pub mod splishsplash;
pub mod vtk;
pub mod vtu;
pub mod xyz;

use std::path::Path;

use glam::Vec3;

use crate::error::{Error, Result};

pub(crate) use self::csv::split_vector as csv_split;
use format::ParticleFormat;
use grid::UniformGrid;

/// Particle data as loaded: positions always, the mapped attributes when the file has them, and every other
/// per-particle array by name.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Particles {
    /// Positions (world, y up after loading).
    pub positions: Vec<[f32; 3]>,
    /// Velocities, when the file has them.
    pub velocities: Option<Vec<[f32; 3]>>,
    /// Densities, when the file has them.
    pub densities: Option<Vec<f32>>,
    /// Particle ids, when the file has them.
    pub ids: Option<Vec<i64>>,
    /// Per-particle radius (e.g. Houdini `pscale`), when mapped.
    pub radii: Option<Vec<f32>>,
    /// Attributes not mapped to one of the above.
    pub extra: Vec<Attribute>,
    /// How many particles of the file were dropped because their position was not finite (NaN, ±inf).
    pub dropped_non_finite: usize,
}

/// One named per-particle array as read from a file (`components` values per particle).
#[derive(Clone, Debug, PartialEq)]
pub struct Attribute {
    /// The array's name in the file.
    pub name: String,
    /// Values per particle (1 or 3).
    pub components: usize,
    /// All values, particle-major.
    pub data: Vec<f64>,
}

/// What a loader returns: positions and every per-particle array it found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Raw {
    /// Positions as stored.
    pub positions: Vec<[f32; 3]>,
    /// Every other per-particle array.
    pub arrays: Vec<Attribute>,
}

/// Which file attribute is what, the up axis and a unit scale (`--velocity-attr`, `--up z`, `--scale`).
#[derive(Clone, Debug, PartialEq)]
pub struct LoadOptions {
    /// Names tried for the velocity, first match wins.
    pub velocity: Vec<String>,
    /// Names tried for the density.
    pub density: Vec<String>,
    /// Names tried for the id.
    pub id: Vec<String>,
    /// Names tried for a per-particle radius.
    pub radius: Vec<String>,
    /// The file's up axis: positions (and vectors) are rotated so that it becomes +y.
    pub z_up: bool,
    /// Multiply positions (and radii, velocities) by this.
    pub scale: f32,
    /// Attributes the user named (flag, name, components): each must exist with that many components, and a
    /// radius must be positive, or the load fails saying so (instead of silently using none).
    pub required: Vec<(&'static str, String, usize)>,
}

impl Default for LoadOptions {
    fn default() -> Self {
        let v = |xs: &[&str]| xs.iter().map(|s| s.to_string()).collect();
        LoadOptions {
            velocity: v(&["velocity", "v", "vel", "velocities"]),
            density: v(&["density", "rho", "densities"]),
            id: v(&["id", "ids", "particle_id"]),
            radius: v(&["radius", "pscale", "radii"]),
            z_up: false,
            scale: 1.0,
            required: vec![],
        }
    }
}

impl Raw {
    /// Map named arrays to the known attributes (first matching name, right component count), convert the
    /// up axis and the scale; everything else stays in `extra`.
    /// Particles whose position is not finite (NaN, ±inf) are dropped with all their attributes; how many is
    /// kept in [`Particles::dropped_non_finite`].
    pub fn into_particles(self, o: &LoadOptions) -> Particles {
        let (raw, dropped) = self.without_non_finite();
        let mut p = raw.map_attributes(o);
        p.dropped_non_finite = dropped;
        p
    }

    /// Removes the particles whose position is not finite, from the positions and from every array whose
    /// length matches the particle count.
    fn without_non_finite(self) -> (Raw, usize) {
        let n = self.positions.len();
        let keep: Vec<bool> = self.positions.iter().map(|p| p.iter().all(|c| c.is_finite())).collect();
        let dropped = keep.iter().filter(|k| !**k).count();
        if dropped == 0 {
            return (self, 0);
        }
        let positions = self.positions.into_iter().zip(&keep).filter(|(_, k)| **k).map(|(p, _)| p).collect();
        let arrays = self
            .arrays
            .into_iter()
            .map(|a| {
                if a.components == 0 || n.checked_mul(a.components) != Some(a.data.len()) {
                    return a;
                }
                let data = a
                    .data
                    .chunks_exact(a.components)
                    .zip(&keep)
                    .filter(|(_, k)| **k)
                    .flat_map(|(c, _)| c.iter().copied())
                    .collect();
                Attribute { data, ..a }
            })
            .collect();
        (Raw { positions, arrays }, dropped)
    }

    fn map_attributes(self, o: &LoadOptions) -> Particles {
        let n = self.positions.len();
        let mut arrays = self.arrays;
        let mut take = |names: &[String], comps: usize| -> Option<Vec<f64>> {
            let k = names.iter().find_map(|want| {
                arrays.iter().position(|a| {
                    a.name.eq_ignore_ascii_case(want)
                        && a.components == comps
                        && n.checked_mul(comps) == Some(a.data.len())
                })
            })?;
            Some(arrays.remove(k).data)
        };
        let vel = take(&o.velocity, 3);
        let dens = take(&o.density, 1);
        let ids = take(&o.id, 1);
        let radii = take(&o.radius, 1);
        let s = o.scale;
        let orient = |v: [f32; 3]| if o.z_up { [v[0], v[2], -v[1]] } else { v };
        Particles {
            positions: self.positions.into_iter().map(|p| orient([p[0] * s, p[1] * s, p[2] * s])).collect(),
            velocities: vel.map(|v| {
                v.chunks_exact(3).map(|c| orient([c[0] as f32 * s, c[1] as f32 * s, c[2] as f32 * s])).collect()
            }),
            densities: dens.map(|v| v.into_iter().map(|x| x as f32).collect()),
            ids: ids.map(|v| v.into_iter().map(|x| x as i64).collect()),
            radii: radii.map(|v| v.into_iter().map(|x| x as f32 * s).collect()),
            extra: arrays,
            dropped_non_finite: 0,
        }
    }
}

impl Particles {
    /// Number of particles.
    pub fn len(&self) -> usize {
        self.positions.len()
    }
    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }
    /// Names of the attributes present besides position (mapped ones first, then the others as in the file).
    pub fn attribute_names(&self) -> Vec<String> {
        let mut v: Vec<String> = vec![];
        if self.velocities.is_some() {
            v.push("velocity (mapped)".into());
        }
        if self.densities.is_some() {
            v.push("density (mapped)".into());
        }
        if self.ids.is_some() {
            v.push("id (mapped)".into());
        }
        if self.radii.is_some() {
            v.push("radius (mapped)".into());
        }
        for a in &self.extra {
            v.push(format!("{} ({} component{})", a.name, a.components, if a.components == 1 { "" } else { "s" }));
        }
        v
    }

    /// The known attributes as named arrays (for writers).
    pub fn to_raw(&self) -> Raw {
        let mut arrays = vec![];
        if let Some(ids) = &self.ids {
            arrays.push(Attribute { name: "id".into(), components: 1, data: ids.iter().map(|&x| x as f64).collect() });
        }
        if let Some(v) = &self.velocities {
            arrays.push(Attribute {
                name: "velocity".into(),
                components: 3,
                data: v.iter().flatten().map(|&x| x as f64).collect(),
            });
        }
        if let Some(d) = &self.densities {
            arrays.push(Attribute {
                name: "density".into(),
                components: 1,
                data: d.iter().map(|&x| x as f64).collect(),
            });
        }
        if let Some(r) = &self.radii {
            arrays.push(Attribute {
                name: "radius".into(),
                components: 1,
                data: r.iter().map(|&x| x as f64).collect(),
            });
        }
        arrays.extend(self.extra.iter().cloned());
        Raw { positions: self.positions.clone(), arrays }
    }
}

/// An axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    /// Minimum corner.
    pub lo: Vec3,
    /// Maximum corner.
    pub hi: Vec3,
}

/// Per-axis percentile bounds: `p` = 0.01 keeps the 1st–99th percentile (a few strays do not matter).
pub fn percentile_bounds(pos: &[[f32; 3]], p: f64) -> Option<Bounds> {
    if pos.is_empty() {
        return None;
    }
    use rayon::prelude::*;
    // The three axes in parallel (a sequence's every frame walks them).
    let per_axis: Vec<Option<(f32, f32)>> = (0..3)
        .into_par_iter()
        .map(|a| {
            // As integers in `f32::total_cmp`'s order (cheaper to select than floats compared by it); the
            // high percentile is selected among the values above the low one only.
            let key = |x: f32| {
                let b = x.to_bits() as i32;
                b ^ (((b >> 31) as u32) >> 1) as i32
            };
            let value = |k: i32| f32::from_bits((k ^ (((k >> 31) as u32) >> 1) as i32) as u32);
            let mut axis: Vec<i32> = pos.iter().map(|q| q[a]).filter(|x| x.is_finite()).map(key).collect();
            if axis.is_empty() {
                return None;
            }
            let n = axis.len();
            let k_lo = ((n - 1) as f64 * p).round() as usize;
            let k_hi = ((n - 1) as f64 * (1.0 - p)).round() as usize;
            let (_, &mut lo, above) = axis.select_nth_unstable(k_lo);
            let hi = match k_hi.cmp(&k_lo) {
                std::cmp::Ordering::Greater => *above.select_nth_unstable(k_hi - k_lo - 1).1,
                std::cmp::Ordering::Equal => lo,
                std::cmp::Ordering::Less => *axis.select_nth_unstable(k_hi).1,
            };
            Some((value(lo), value(hi)))
        })
        .collect();
    let mut lo = [0f32; 3];
    let mut hi = [0f32; 3];
    for (a, b) in per_axis.into_iter().enumerate() {
        (lo[a], hi[a]) = b?;
    }
    Some(Bounds { lo: Vec3::from(lo), hi: Vec3::from(hi) })
}

/// The box of the fluid, and how many particles lie outside it: the bounding box of the particles within the
/// 1st–99th percentile box (of at most [`STRAY_SAMPLE`] of them, evenly strided) grown on every side by [`STRAY_REACH`] times its largest side (and at least `margin`). A
/// stray particle (one at x = 1e6 in a tank of a metre) is left out, so it cannot stretch a grid or lattice
/// built over the box until the water vanishes; splashes and droplets around the water stay in.
/// `None` without finite positions.
pub fn fluid_bounds(pos: &[[f32; 3]], margin: f32) -> Option<(Bounds, usize)> {
    // The percentile box only places the stray limit, four of its sides out: an evenly strided sample of at
    // most STRAY_SAMPLE particles places it as well (a sequence walks this every frame).
    let stride = pos.len().div_ceil(STRAY_SAMPLE).max(1);
    let core = if stride > 1 {
        let sample: Vec<[f32; 3]> = pos.iter().step_by(stride).copied().collect();
        percentile_bounds(&sample, 0.01).or_else(|| percentile_bounds(pos, 0.01))?
    } else {
        percentile_bounds(pos, 0.01)?
    };
    // The largest side, on every axis: water that spread flat still has its splashes above it.
    let grow = Vec3::splat(((core.hi - core.lo).max_element() * STRAY_REACH).max(margin.max(0.0)));
    let (reach_lo, reach_hi) = (core.lo - grow, core.hi + grow);
    let mut b = Bounds { lo: Vec3::INFINITY, hi: Vec3::NEG_INFINITY };
    let mut out = 0;
    for p in pos {
        let v = Vec3::from(*p);
        if !v.is_finite() {
            continue;
        }
        if v.cmplt(reach_lo).any() || v.cmpgt(reach_hi).any() {
            out += 1;
        } else {
            b.lo = b.lo.min(v);
            b.hi = b.hi.max(v);
        }
    }
    Some((b, out))
}

/// How far from the fluid's 1st–99th percentile box a particle still belongs to the water, in multiples of
/// the box's largest side: a sheet that ran up a wall or a splash's droplets are within it (the shared dam
/// break's highest droplets, over water spread 0.5 m deep, are 1.9 m above it: half a side), a particle a
/// thousand tank-lengths away is not.
pub const STRAY_REACH: f32 = 4.0;

/// The most particles [`fluid_bounds`] takes the percentile box of (an evenly strided sample of larger sets).
pub const STRAY_SAMPLE: usize = 16_384;

/// The one warning about strays left out of `what` (the iso surface, the mesh).
pub fn stray_warning(strays: usize, what: &str) -> String {
    format!(
        "warning: {strays} particle{} far from the fluid (more than {STRAY_REACH} box sides beyond its 1st–99th \
         percentile box) left out of {what}",
        if strays == 1 { " is" } else { "s are" }
    )
}

/// The positions inside [`fluid_bounds`] (in order), and how many strays were left out.
pub fn without_strays(pos: &[[f32; 3]], margin: f32) -> (std::borrow::Cow<'_, [[f32; 3]]>, usize) {
    match kept_indices(pos, margin) {
        (Some(kept), strays) => (kept.iter().map(|&i| pos[i as usize]).collect::<Vec<_>>().into(), strays),
        (None, _) => (pos.into(), 0),
    }
}

/// The indices of the particles [`without_strays`] keeps (in order), or None when it keeps them all; and how
/// many strays were left out.
pub fn kept_indices(pos: &[[f32; 3]], margin: f32) -> (Option<Vec<u32>>, usize) {
    match fluid_bounds(pos, margin) {
        Some((b, strays)) if strays > 0 => {
            let inside = |p: Vec3| p.cmpge(b.lo).all() && p.cmple(b.hi).all();
            ((0..pos.len() as u32).filter(|&i| inside(Vec3::from(pos[i as usize]))).collect::<Vec<_>>().into(), strays)
        }
        _ => (None, 0),
    }
}

/// Median nearest-neighbour distance over (up to) 4,096 sample particles. SPH samplers start particles on a
/// lattice one spacing (2 r) apart; once the fluid moves, neighbours crowd in a disordered packing and this
/// distance shrinks (dam break 59k: 2 r at frame 1, 1.75 r at frame 20), so it is only a length scale here:
/// [`estimate_radius`] measures the number density instead.
pub fn estimate_spacing(pos: &[[f32; 3]]) -> Option<f32> {
    let b = percentile_bounds(pos, 0.0)?;
    let n = pos.len();
    if n < 2 {
        return None;
    }
    let extent = (b.hi - b.lo).max(Vec3::splat(1e-6));
    // A cell holding about 3 particles on average; grow it until most samples find a neighbour.
    let mut cell = ((extent.x * extent.y * extent.z / n as f32).cbrt() * 1.5).max(1e-6);
    for _ in 0..4 {
        let grid = UniformGrid::new(pos, cell);
        let mut dists = vec![];
        let mut samples = 0;
        for i in grid::sample_indices(n, 4096) {
            samples += 1;
            let mut best = f32::INFINITY;
            grid.for_each_within(pos[i], cell, |j, d| {
                if j != i && d > 0.0 && d < best {
                    best = d;
                }
            });
            if best.is_finite() {
                dists.push(best);
            }
        }
        if !dists.is_empty() && dists.len() * 2 >= samples {
            let m = dists.len() / 2;
            return Some(*dists.select_nth_unstable_by(m, f32::total_cmp).1);
        }
        cell *= 4.0;
    }
    None
}

/// Particle radius from the number density of the fluid's bulk.
///
/// Incompressible SPH keeps the number density near 1/(2r)³ (particles start on a lattice of spacing 2r), while
/// the nearest-neighbour distance shrinks by 12–15 % once the packing becomes disordered. So: an SPH estimate of
/// the number density n_i = Σ_j W(|x_i − x_j|, h) (cubic spline normalised to 1, support h = 3 × the median
/// nearest-neighbour distance) at up to 4,096 sample particles; its 95th percentile stands for the bulk (surface
/// particles miss neighbours and count low); r = ½ n^(−1/3). Measured on the shared SPlisHSPlasH sequences
/// (true 0.0125 / 0.025): dam break 59k frames 1, 20, 50 → 0.01249, 0.01249, 0.01250; 6,859 frames 1, 40 →
/// 0.02499, 0.02516. Falls back to half the spacing when the set is too sparse to have a bulk; the result is kept
/// within [½, 0.7] × the nearest-neighbour distance.
pub fn estimate_radius(pos: &[[f32; 3]]) -> Option<f32> {
    let s = estimate_spacing(pos)?;
    let h = 3.0 * s;
    let grid = UniformGrid::new(pos, h);
    let w = |q: f32| -> f32 {
        // Cubic spline, support 1, ∫W dV = 1 (Monaghan), scaled by 1/h³ below.
        let k = 8.0 / std::f32::consts::PI;
        if q < 0.5 {
            k * (6.0 * q * q * q - 6.0 * q * q + 1.0)
        } else if q < 1.0 {
            k * 2.0 * (1.0 - q).powi(3)
        } else {
            0.0
        }
    };
    let mut dens: Vec<f32> = grid::sample_indices(pos.len(), 4096)
        .filter(|&i| pos[i].iter().all(|c| c.is_finite()))
        .map(|i| {
            let mut sum = 0.0;
            grid.for_each_within(pos[i], h, |_, d| sum += w(d / h));
            sum / (h * h * h)
        })
        .collect();
    if dens.len() < 8 {
        return Some(0.5 * s);
    }
    let k = ((dens.len() - 1) as f64 * 0.95).round() as usize;
    let n = *dens.select_nth_unstable_by(k, f32::total_cmp).1;
    let r = 0.5 / n.cbrt();
    Some(if r.is_finite() { r.clamp(0.5 * s, 0.7 * s) } else { 0.5 * s })
}

/// Isolated particles (NVIDIA patent US 8,947,430: particles of low density are left out of the surface and
/// drawn apart): a particle is isolated when its density is below `threshold` × the median density. The density is the
/// file's `density` attribute when present, else the number of neighbours within 4 radii.
pub fn isolated_mask(p: &Particles, radius: f32, threshold: f32) -> Vec<bool> {
    isolated_mask_with(p, radius, threshold, false)
}

/// [`isolated_mask`], optionally ignoring the file's densities and counting neighbours within 4 radii instead
/// (the kernel support of a surface reconstruction such as splashsurf's).
pub fn isolated_mask_with(p: &Particles, radius: f32, threshold: f32, neighbours: bool) -> Vec<bool> {
    if threshold <= 0.0 || p.is_empty() {
        return vec![false; p.len()];
    }
    let dens: Vec<f32> = match &p.densities {
        Some(d) if !neighbours => d.clone(),
        _ => neighbour_counts(&p.positions, 4.0 * radius).into_iter().map(|c| c as f32).collect(),
    };
    let mut sorted: Vec<f32> = dens.iter().copied().filter(|d| d.is_finite()).collect();
    if sorted.is_empty() {
        return vec![false; p.len()];
    }
    let m = sorted.len() / 2;
    let rest = *sorted.select_nth_unstable_by(m, f32::total_cmp).1;
    // Written negated on purpose: a NaN density counts as isolated.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    dens.iter().map(|&d| !(d >= threshold * rest)).collect()
}

/// Number of other particles within `h` of each particle.
pub fn neighbour_counts(pos: &[[f32; 3]], h: f32) -> Vec<u32> {
    let h = h.max(1e-9);
    let grid = UniformGrid::new(pos, h);
    (0..pos.len())
        .map(|i| {
            let mut n = 0;
            grid.for_each_within(pos[i], h, |j, _| n += u32::from(j != i));
            n
        })
        .collect()
}

/// Detect the format of a file's bytes (see [`format::detect`]).
pub fn detect_format(path: &Path, bytes: &[u8]) -> Option<&'static dyn ParticleFormat> {
    format::detect(path, bytes)
}

/// Parse bytes of a known format into named arrays.
pub fn parse_raw(format: &dyn ParticleFormat, path: &Path, bytes: &[u8]) -> Result<Raw> {
    format.parse(path, bytes)
}

/// Load a particle file with the default attribute mapping.
pub fn load(path: &Path) -> Result<Particles> {
    load_with(path, &LoadOptions::default())
}

/// Load a particle file, detecting its format, mapping attributes by `o`.
pub fn load_with(path: &Path, o: &LoadOptions) -> Result<Particles> {
    let bytes = crate::input::read(path)?;
    let format = detect_format(path, &bytes).ok_or_else(|| Error::Parse {
        path: path.to_path_buf(),
        offset: 0,
        reason: format!("unknown particle format (expected one of: {})", format::describe()),
    })?;
    let raw = parse_raw(format, path, &bytes)?;
    // A file with no particles is a valid frame (an export's frame before anything spawned, a fluid that has
    // drained): every reader takes it; what needs particles (a fitted camera or radius) says so itself.
    let empty = raw.positions.is_empty();
    if !empty {
        check_required(path, &raw, o)?;
    }
    let p = raw.into_particles(o);
    if p.dropped_non_finite > 0 {
        // The one warning a user sees: such particles are never rendered.
        eprintln!(
            "warning: {}: dropped {} particle{} with a non-finite position (NaN or inf)",
            path.display(),
            p.dropped_non_finite,
            if p.dropped_non_finite == 1 { "" } else { "s" }
        );
    }
    if p.is_empty() && !empty {
        return Err(Error::Parse {
            path: path.to_path_buf(),
            offset: 0,
            reason: "no particle has a finite position".into(),
        });
    }
    Ok(p)
}

/// The attributes the user named exist, with the components they need; a radius is positive and finite.
fn check_required(path: &Path, raw: &Raw, o: &LoadOptions) -> Result<()> {
    let invalid = |reason: String| Err(Error::Invalid(format!("{}: {reason}", path.display())));
    for (flag, name, comps) in &o.required {
        let Some(a) = raw.arrays.iter().find(|a| a.name.eq_ignore_ascii_case(name)) else {
            let have: Vec<&str> = raw.arrays.iter().map(|a| a.name.as_str()).collect();
            return invalid(format!(
                "{flag} {name}: no such attribute (the file has: {})",
                if have.is_empty() { "positions only".to_string() } else { have.join(", ") }
            ));
        };
        if a.components != *comps || Some(a.data.len()) != raw.positions.len().checked_mul(*comps) {
            return invalid(format!(
                "{flag} {name}: the attribute has {} component(s) per particle, {comps} are needed",
                a.components
            ));
        }
        if *flag == "--radius-attr" {
            if let Some((i, x)) = a.data.iter().enumerate().find(|(_, x)| !(x.is_finite() && **x > 0.0)) {
                return invalid(format!("{flag} {name}: a radius must be positive; particle {i} has {x}"));
            }
        }
    }
    Ok(())
}

/// Write particles (positions and the mapped attributes: id, velocity, density) as a particle cache, by the
/// extension: `.bgeo` (gzip-compressed classic BGEO, as Partio and SPlisHSPlasH write it) or `.vtk` (legacy
/// binary VTK, as SPlisHSPlasH writes it). Both are read back by `meniscus` and by splashsurf.
pub fn write_particles(path: &Path, p: &Particles) -> Result<()> {
    let kind = crate::output::FileKind::by_extension(path, &crate::output::PARTICLE_KINDS)?;
    let bytes = match kind {
        crate::output::FileKind::Bgeo => bgeo::write(&p.to_raw(), true),
        _ => vtk::write(&p.to_raw(), true),
    };
    crate::output::write_atomic(path, kind, |w| std::io::Write::write_all(w, &bytes))
}

#[cfg(test)]
mod tests;
