//! The particles' neighbour grid with their weights and kernels on the device, shared by the iso surface (its
//! field, the smoothed field's lattice) and the spheres' ellipsoids (Yu & Turk 2013), and the host analysis of a
//! particle set a sequence's loader may compute ahead ([`analyse`]). Neither technique imports the other: both
//! use this module. `crate::field::iso` is the CPU reference.
//!
//! Its files: this one (the buffers' life: built on the GPU or uploaded, kept while a sequence's box fits),
//! [`buffers`] (what the shaders read), [`programs`] (the grid's build and `iso_density`), [`anisotropy`] (the
//! `anisotropy` pass) and [`params`] (the `[anisotropy]` section).

pub mod anisotropy;
mod buffers;
pub mod params;
pub mod programs;

pub use buffers::{IsoBuffers, IsoPush};

use anisotropy::Anisotropy;
use programs::GridPrograms;

use ash::vk;

use crate::error::Result;
use crate::field::iso as field;
use crate::gpu::transfer::upload_buffer;
use crate::gpu::{Buffer, FrameCtx};
use crate::settings::Settings;

use super::{Prepare, SurfaceFrame};

/// The particles' neighbour grid with their weights and kernels on the device (shared by the iso surface
/// and the spheres' ellipsoids), and the particle generation it was built for.
#[derive(Default)]
pub struct IsoResources {
    buffers: Option<IsoBuffers>,
    built_for: Option<u64>,
    /// The fluid's box and strays for (particle generation, reach bits): a still frame does not walk its
    /// particles again (2.4–6 ms a frame on the H100 machine's host for 59k–159k particles, 33 ms for 814k).
    bounds: Option<(u64, u32, FluidBox)>,
    /// The ray cast's and the smoothed field's parameters in world units (`Settings::iso_params`), derived once
    /// per change of the settings they come from, not per frame.
    derived: Option<(IsoKey, crate::field::iso::IsoParams)>,
    /// Its programs (the grid's build and weights, the anisotropic kernels), built on the first prepare.
    programs: Option<(GridPrograms, Anisotropy)>,
}

/// What `Settings::iso_params` derives from: `[iso]`, `[anisotropy]`, the kernel and the radius.
type IsoKey = (crate::surface::iso::params::Params, params::Params, crate::settings::Kernel, u32);

/// `scene::fluid_bounds` of a particle set: the box and the strays left out (None: no finite particle).
type FluidBox = Option<(crate::scene::Bounds, usize)>;

impl IsoResources {
    /// Derive the parameters from `s` when what they come from changed (a prepare step).
    fn derive(&mut self, s: &Settings) -> &crate::field::iso::IsoParams {
        let key: IsoKey = (s.iso.clone(), s.anisotropy.clone(), s.kernel, s.radius.to_bits());
        if self.derived.as_ref().is_none_or(|(k, _)| *k != key) {
            self.derived = Some((key, s.iso_params()));
        }
        &self.derived.as_ref().expect("derived").1
    }

    /// The particles far from the fluid that the grid's box left out, for the particle generation it was built
    /// for (`Technique::strays`: the caller warns; the library does not print).
    pub fn strays(&self) -> Option<(u64, usize)> {
        self.bounds.and_then(|(g, _, b)| b.map(|(_, n)| (g, n)))
    }

    /// The parameters derived at the last prepare (`Settings::iso_params`).
    pub fn params(&self) -> Option<&crate::field::iso::IsoParams> {
        self.derived.as_ref().map(|(_, p)| p)
    }

    /// Prepare for a frame: the parameters, the grid (`support`; cells at least the parameters' reach wide),
    /// and the smoothed field when `[iso] smoothing` asks for it.
    pub fn prepare(&mut self, p: &Prepare) -> Result<()> {
        if self.programs.is_none() {
            self.programs = Some((GridPrograms::new(p.gpu)?, Anisotropy::new(p.gpu)?));
        }
        let s = p.settings;
        let h = s.iso.support * s.radius;
        let reach = self.derive(s).reach(h);
        self.ensure(p, h, reach)
    }

    /// Prepare the grid for kernels of `support` (world units) alone, cells `support` wide: what the mesh
    /// surface's field needs (no smoothed field, no anisotropic kernels; [`IsoResources::record_weights`]).
    pub fn prepare_support(&mut self, p: &Prepare, support: f32) -> Result<()> {
        if self.programs.is_none() {
            self.programs = Some((GridPrograms::new(p.gpu)?, Anisotropy::new(p.gpu)?));
        }
        self.ensure(p, support, support)
    }

    /// The box the grid spans: the fluid's (the particles without strays; a simulation's container), or the
    /// host-built grid's cells.
    pub fn fluid_box(&self) -> Option<crate::scene::Bounds> {
        let b = self.buffers.as_ref()?;
        if b.gpu.is_some() {
            return self.bounds.and_then(|(_, _, f)| f.map(|(bounds, _)| bounds));
        }
        let o = b.shape.origin;
        let lo = glam::Vec3::new(o[0], o[1], o[2]);
        let d = b.shape.dims;
        Some(crate::scene::Bounds { lo, hi: lo + glam::Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32) * o[3] })
    }

    /// Record the grid's build (when the particles changed) and each point's weight 1/n_j (`iso_density`, no
    /// lattice order, no kernels): the colour field's inputs.
    pub(crate) fn record_weights(&self, ctx: &mut FrameCtx, f: &SurfaceFrame) -> Option<&IsoBuffers> {
        let (b, (grid, _)) = (self.buffers.as_ref()?, self.programs.as_ref()?);
        grid.record_grid(ctx, f.particles.0, f.particles.1, b);
        grid.record_density(ctx, f.frame, b, false);
        Some(b)
    }

    /// The buffers, once built.
    pub fn buffers(&self) -> Option<&IsoBuffers> {
        self.buffers.as_ref()
    }

    /// The grid of the current particles for kernel `support` (world units), unless it is there already.
    /// Without isolated particles the grid is built on the GPU from the particle buffer (the `grid` pass in the frame: no
    /// CPU work per frame, and GPU-resident particles work too; the buffers are kept while the shape holds);
    /// with them the CPU builds it without them and uploads it. The cells are at least `reach` (≥ the
    /// kernel `support`) wide: the farthest a kernel reaches from its particle. The grid spans the fluid, not
    /// a stray particle far from it (the GPU grid clamps such a particle into its edge cell, where its kernel
    /// reaches nothing: it is left out of the surface, and said so).
    fn ensure(&mut self, p: &Prepare, support: f32, reach: f32) -> Result<()> {
        let (particles, gpu) = (p.particles, p.gpu);
        let stale = self.built_for != Some(particles.generation());
        // The anisotropic kernels' buffer only where they are used (48 bytes a point).
        let aniso = p.settings.kernel == crate::settings::Kernel::Anisotropic;
        let aniso_bytes = |points: u64| if aniso { points * 48 } else { 16 };
        if !particles.has_isolated() {
            let key = (particles.generation(), reach.to_bits());
            let bounds = match self.bounds {
                Some((g, r, b)) if (g, r) == key => b,
                _ => {
                    // Computed ahead by the set's loader, or here.
                    let b = match particles.analysis().filter(|a| a.reach.to_bits() == key.1) {
                        Some(a) => a.bounds,
                        None => crate::scene::fluid_bounds(particles.positions(), reach),
                    };
                    self.bounds = Some((key.0, key.1, b));
                    b
                }
            };
            let n = particles.count();
            let shape = grid_shape(bounds, reach, n);
            let d = shape.dims;
            let push = IsoPush::grid(shape.origin_cell, [d[0], d[1], d[2], n], support);
            if let Some(b) = &mut self.buffers {
                let fits = b.aniso.size >= aniso_bytes(n.max(1) as u64);
                // A sequence's box moves every frame: the buffers are kept while they hold the new grid (they are
                // made with room to spare), so a new frame neither reallocates them nor waits for the GPU first.
                if let Some(g) = b.gpu.as_mut().filter(|g| fits && g.holds(&shape, n)) {
                    let moved = g.shape != shape;
                    g.shape = shape;
                    if stale || moved {
                        b.rebuild.set(true);
                        b.mark_stale();
                        self.built_for = Some(particles.generation());
                    }
                    if b.shape.support() != push.support() {
                        b.mark_stale();
                    }
                    b.shape = push;
                    return Ok(());
                }
            }
            p.executor.wait_idle()?;
            self.buffers = None;
            // A quarter more points and cells than this frame's: the next frames of a sequence fit.
            let room = |x: u32| x.saturating_add(x / 4);
            let cap = room(n.max(1));
            let cell_room = room(shape.cells());
            // TRANSFER_SRC: the tests read the grid and kernels back.
            let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC;
            let buf = |name: &str, bytes: u64, format| Buffer::texels(gpu, name, bytes.max(16), usage, format);
            self.buffers = Some(IsoBuffers {
                points: buf("iso_points", cap as u64 * 16, IsoBuffers::POINTS)?,
                cells: buf("iso_cells", cell_room as u64 * 8, IsoBuffers::CELLS)?,
                cells_empty: buf("iso_cells_empty", cell_room as u64 * 8, IsoBuffers::CELLS)?,
                empty_scratch: buf("iso_empty_scratch", cell_room as u64 * 8, IsoBuffers::CELLS)?,
                weighted: buf("iso_weighted", cap as u64 * 16, IsoBuffers::WEIGHTED)?,
                aniso: buf("iso_aniso", aniso_bytes(cap as u64), IsoBuffers::ANISO)?,
                counts: buf("iso_counts", cap as u64 * 8, IsoBuffers::COUNTS)?,
                lattice: buf("iso_lattice", cap as u64 * 8, IsoBuffers::COUNTS)?,
                shape: push,
                gpu: Some(crate::compute::grid::GridBuffers::with_room(gpu, "iso", shape, cell_room, cap)?),
                rebuild: std::cell::Cell::new(true),
                weights_stale: std::cell::Cell::new(true),
                kernels_for: std::cell::Cell::new(None),
                ordered: std::cell::Cell::new(false),
                generation: std::cell::Cell::new(buffers::next_generation()),
            });
            self.built_for = Some(particles.generation());
            return Ok(());
        }
        if !stale
            && self.buffers.as_ref().is_some_and(|b| {
                b.gpu.is_none()
                    && b.shape.support() == support
                    && b.shape.origin[3] >= reach
                    && b.aniso.size >= aniso_bytes(b.shape.dims[3].max(1) as u64)
            })
        {
            return Ok(());
        }
        // As on the GPU path: the grid spans the fluid, strays far from it are left out.
        let pts = crate::scene::without_strays(&particles.surface_positions(), reach).0.into_owned();
        let grid = field::IsoGrid::build_reaching(&pts, support, reach);
        p.executor.wait_idle()?;
        self.buffers = None;
        let points = upload_buffer(gpu, "iso_points", bytemuck::cast_slice(&grid.points), None)?
            .with_texel_view(IsoBuffers::POINTS)?;
        let cells = upload_buffer(gpu, "iso_cells", bytemuck::cast_slice(&grid.cells), None)?
            .with_texel_view(IsoBuffers::CELLS)?;
        let buf = |name: &str, per_point: u64, format| {
            let bytes = (grid.points.len() as u64 * per_point).max(per_point.max(16));
            Buffer::texels(gpu, name, bytes, vk::BufferUsageFlags::STORAGE_BUFFER, format)
        };
        let weighted = buf("iso_weighted", 16, IsoBuffers::WEIGHTED)?;
        let aniso = Buffer::texels(
            gpu,
            "iso_aniso",
            aniso_bytes(grid.points.len().max(1) as u64),
            vk::BufferUsageFlags::STORAGE_BUFFER,
            IsoBuffers::ANISO,
        )?;
        let counts = buf("iso_counts", 8, IsoBuffers::COUNTS)?;
        let lattice = buf("iso_lattice", 8, IsoBuffers::COUNTS)?;
        let cell_buf = |name: &str| {
            let bytes = (grid.cells.len() as u64 * 8).max(16);
            Buffer::texels(gpu, name, bytes, vk::BufferUsageFlags::STORAGE_BUFFER, IsoBuffers::CELLS)
        };
        let (cells_empty, empty_scratch) = (cell_buf("iso_cells_empty")?, cell_buf("iso_empty_scratch")?);
        let shape = IsoPush::shape(&grid);
        self.buffers = Some(IsoBuffers {
            points,
            cells,
            cells_empty,
            empty_scratch,
            weighted,
            aniso,
            counts,
            lattice,
            shape,
            gpu: None,
            rebuild: std::cell::Cell::new(false),
            weights_stale: std::cell::Cell::new(true),
            kernels_for: std::cell::Cell::new(None),
            ordered: std::cell::Cell::new(false),
            generation: std::cell::Cell::new(buffers::next_generation()),
        });
        self.built_for = Some(particles.generation());
        Ok(())
    }

    /// Record the grid's build (when the particles changed) and, with `kernel = "anisotropic"`, the kernels;
    /// `weights`: also each particle's 1/n_j (`iso_density`: the iso surface's field, not the ellipsoids').
    pub(crate) fn record(&self, ctx: &mut FrameCtx, f: &SurfaceFrame, weights: bool) -> Option<&IsoBuffers> {
        let (b, params, (grid, anisotropy)) = (self.buffers.as_ref()?, self.params()?, self.programs.as_ref()?);
        grid.record_grid(ctx, f.particles.0, f.particles.1, b);
        if weights {
            // The lattice order only where the smoothed field widens its blur by it.
            let order = params.volume.is_some_and(|v| v.lattice_sigma != v.sigma);
            grid.record_density(ctx, f.frame, b, order);
        }
        if let Some(a) = &params.aniso {
            anisotropy.record(ctx, f.frame, b, a);
        }
        Some(b)
    }
}

/// The GPU grid over a set's fluid box (`scene::fluid_bounds`, none: a point at the origin) for kernels reaching
/// `reach`: cells at least `reach` wide (`UniformGrid::shape_for`).
fn grid_shape(bounds: FluidBox, reach: f32, n: u32) -> crate::compute::grid::GridShape {
    let (lo, hi) = match bounds {
        Some((b, _)) if b.lo.x <= b.hi.x => (b.lo, b.hi),
        _ => (glam::Vec3::ZERO, glam::Vec3::ZERO),
    };
    let (cell, d) = crate::scene::grid::UniformGrid::shape_for(lo, hi, reach, n as usize);
    crate::compute::grid::GridShape {
        origin_cell: [lo.x, lo.y, lo.z, cell],
        dims: [d[0], d[1], d[2], d[0] * d[1] * d[2]],
    }
}

/// The smoothed field's lattice over a grid's box (corner and cell side `o`, `d` cells per axis).
pub(crate) fn volume_shape(
    o: [f32; 4],
    d: [u32; 3],
    params: &crate::field::volume::VolumeParams,
) -> std::result::Result<crate::field::volume::VolumeShape, String> {
    let lo = glam::Vec3::new(o[0], o[1], o[2]);
    let hi = lo + glam::Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32) * o[3];
    crate::field::volume::VolumeShape::around(lo, hi, params)
}

/// The bricks of `shape` the positions mark (the pool's size).
pub(crate) fn marked_bricks(shape: &crate::field::volume::VolumeShape, positions: &[[f32; 3]]) -> u32 {
    shape.marked(positions, |&x| glam::Vec3::from(x)).iter().filter(|&&m| m).count() as u32
}

/// The host's analysis of a particle set for the default surface's prepare under `settings` — what a new set's
/// frame would otherwise compute on the render thread: the fluid's box and strays, and the smoothed field's
/// marked bricks — for its loader to compute ahead (a sequence's prefetch thread) and hand over with the set
/// (`Upload::Scene::ahead`). The same functions as the prepare, so the frame is the same either way (test:
/// `an_analysis_computed_ahead_renders_the_same_frame`). None where that prepare would not use it: another
/// surface, or `[isolated]` on (a set with isolated particles builds its grid on the host, without the box).
pub fn analyse(positions: &[[f32; 3]], settings: &Settings) -> Option<crate::particles::SetAnalysis> {
    if settings.surface != crate::settings::Surface::Iso || settings.isolated.density > 0.0 {
        return None;
    }
    let params = settings.iso_params();
    let reach = params.reach(settings.iso.support * settings.radius);
    let bounds = crate::scene::fluid_bounds(positions, reach);
    let volume = params.volume.and_then(|v| {
        let g = grid_shape(bounds, reach, positions.len() as u32);
        let shape = volume_shape(g.origin_cell, [g.dims[0], g.dims[1], g.dims[2]], &v).ok()?;
        Some((shape, marked_bricks(&shape, positions)))
    });
    Some(crate::particles::SetAnalysis { fingerprint: crate::particles::fingerprint(positions), reach, bounds, volume })
}
