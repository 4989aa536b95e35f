//! The mesh surface (`--surface mesh`, `--preset smooth`): the marching-cubes mesh of the iso field, extracted
//! where `[mesh] extraction` says ([`params::Extraction`]):
//! * on the CPU (`extract`, rayon), optionally smoothed with splashsurf's feature-weighted Laplacian (`smooth`),
//!   its BVH ray-cast per pixel by the `mesh` pass ([`cast`]); extracted again whenever the particles change;
//! * on the GPU inside the frame ([`live`]): the `mc` pass's stages on the renderer's particle grid, smoothed
//!   there too (`compute::smooth`'s passes), the triangles drawn by a raster pass straight from the device's
//!   buffers — live with GPU-written particles.
//!
//! `auto` takes the GPU on a GPU, the CPU on a CPU driver (lavapipe emulates the marching cubes slower than the
//! CPU runs it), and the GPU for a simulation's particles (they never reach the host);
//! [`FluidMesh::path`] says which and why. Its files: this one, [`params`] (the `[mesh]` section), [`cast`],
//! [`live`], their shaders in shaders_glsl/mesh/ (the `mc` stages in shaders_glsl/mc_*.comp).

pub mod cast;
pub mod live;
pub mod params;

use crate::error::{Error, Result};
use crate::field::{extract, smooth};
use crate::gpu::recording::{Part, Recording};
use crate::gpu::transfer::upload_buffer;
use crate::gpu::FrameCtx;
use crate::passes::background::BvhBuffers;
use crate::scene::geometry::{Geometry, GpuBvh};

use super::grid::IsoResources;
use super::{Kernels, Prepare, SurfaceFrame, Technique};

/// What a mesh is made from: [support, cube, threshold] in world units, the smoothing, the particles.
type MeshKey = ([f32; 3], smooth::SmoothParams, u64);

/// The mesh technique: the CPU-extracted mesh's BVH, or the live mesh on the device.
#[derive(Default)]
pub struct FluidMesh {
    bvh: Option<(BvhBuffers, MeshKey)>,
    /// The `mesh` pass, built on the first prepare.
    cast: Option<cast::MeshCast>,
    /// Seconds (CPU) the last extraction and BVH build took, and the mesh's vertex and triangle counts.
    stats: Option<(f64, usize, usize)>,
    /// The particles' grid and weights on the device (the live mesh's field).
    grid: IsoResources,
    /// The live mesh, built when first used.
    live: Option<live::LiveMesh>,
    /// Where the latest prepare extracts, and why.
    path: Option<(params::Extraction, String)>,
}

impl FluidMesh {
    /// Seconds its last host build took, and the mesh's vertex and triangle counts, once built (the CPU path).
    pub fn mesh_stats(&self) -> Option<(f64, usize, usize)> {
        self.stats
    }

    /// Where the latest prepare extracted the mesh (`params::Extraction::Cpu` or `params::Extraction::Gpu`) and why.
    pub fn path(&self) -> Option<(params::Extraction, &str)> {
        self.path.as_ref().map(|(e, w)| (*e, w.as_str()))
    }

    /// The live mesh's work in its latest extraction (after its frame finished), on the GPU path.
    pub fn live_work(&self) -> Option<crate::work::MeshWork> {
        match self.path {
            Some((params::Extraction::Gpu, _)) => self.live.as_ref()?.work(),
            _ => None,
        }
    }
}

/// Where `[mesh] extraction = e` extracts for this device and these particles, and why (see the module).
pub fn choose(e: params::Extraction, gpu: &crate::gpu::Gpu, gpu_written: bool) -> Result<(params::Extraction, String)> {
    let cpu_driver = gpu.info.device_type == "CPU";
    Ok(match e {
        params::Extraction::Cpu if gpu_written => {
            return Err(Error::Invalid(
                "[mesh] extraction = \"cpu\" cannot mesh particles written on the GPU (a simulation's): they never \
                 reach the host; use \"gpu\" or \"auto\""
                    .into(),
            ))
        }
        params::Extraction::Cpu => (params::Extraction::Cpu, "[mesh] extraction = \"cpu\"".into()),
        params::Extraction::Gpu => (params::Extraction::Gpu, "[mesh] extraction = \"gpu\"".into()),
        params::Extraction::Auto if gpu_written => (
            params::Extraction::Gpu,
            "the particles are written on the GPU (a simulation's): they never reach the host".into(),
        ),
        params::Extraction::Auto if cpu_driver => (
            params::Extraction::Cpu,
            format!("{} is a CPU driver: its marching cubes is an emulation, slower than the CPU's", gpu.info.name),
        ),
        params::Extraction::Auto => (params::Extraction::Gpu, format!("{} is a GPU", gpu.info.name)),
    })
}

impl Technique for FluidMesh {
    /// Choose where to extract; on the CPU extract the iso-surface mesh of the current particles (isolated
    /// particles and strays left out) with the `[iso]` field and the `[mesh]` cube size and upload its BVH unless
    /// it is there already; on the GPU bring the grid and the live mesh's buffers up to date.
    fn prepare(&mut self, p: &Prepare) -> Result<()> {
        let s = p.settings;
        let path = choose(s.mesh.extraction, p.gpu, p.particles.gpu_written())?;
        let on_gpu = path.0 == params::Extraction::Gpu;
        self.path = Some(path);
        let field = [s.iso.support * s.radius, s.mesh.cube * s.radius, s.iso.threshold];
        let smoothing = smooth::SmoothParams {
            iterations: s.mesh.smoothing_iters,
            weights: s.mesh.smoothing_weights,
            ..Default::default()
        };
        if on_gpu {
            self.grid.prepare_support(p, field[0])?;
            if self.live.is_none() {
                self.live = Some(live::LiveMesh::new(p.gpu)?);
            }
            let (Some(b), Some(bx), Some(l)) = (self.grid.buffers(), self.grid.fluid_box(), self.live.as_mut()) else {
                return Ok(());
            };
            let (generation, points) = (b.generation.get(), b.shape.dims[3]);
            let per_cube = s.mesh.live_triangles_per_cube;
            return l.prepare(
                p,
                (bx.lo, bx.hi),
                (field[0], field[1], field[2]),
                smoothing,
                (generation, points),
                per_cube,
            );
        }
        if self.cast.is_none() {
            self.cast = Some(cast::MeshCast::new(p.gpu)?);
        }
        let key = (field, smoothing, p.particles.generation());
        if self.bvh.as_ref().is_some_and(|m| m.1 == key) {
            return Ok(());
        }
        let t0 = std::time::Instant::now();
        let pts = crate::scene::without_strays(&p.particles.surface_positions(), field[0]).0.into_owned();
        let grid = crate::field::iso::IsoGrid::build(&pts, field[0]);
        let inv = grid.inv_density();
        let params = extract::ExtractParams::new(field[1], field[2]);
        extract::check_lattice(&grid, field[1])?;
        let mut m = extract::extract(&grid, &inv, &params);
        smooth::smooth(&mut m, &grid, &inv, &smoothing);
        let tris = m.triangles.iter().map(|t| t.map(|i| glam::Vec3::from(m.vertices[i as usize]))).collect();
        let bvh = GpuBvh::build(&Geometry { triangles: tris });
        self.stats = Some((t0.elapsed().as_secs_f64(), m.vertices.len(), m.triangles.len()));
        p.executor.wait_idle()?;
        let buffers = BvhBuffers {
            nodes: upload_buffer(p.gpu, "fluid_mesh_nodes", bytemuck::cast_slice(&bvh.nodes), None)?,
            triangles: upload_buffer(p.gpu, "fluid_mesh_triangles", bytemuck::cast_slice(&bvh.triangles), None)?,
            node_count: bvh.len() as u32,
        };
        self.bvh = Some((buffers, key));
        Ok(())
    }

    fn record_kernels<'a>(&'a self, rec: &mut Recording, f: &SurfaceFrame<'a>) -> Option<Kernels<'a>> {
        if let (Some((params::Extraction::Gpu, _)), Some(l)) = (&self.path, &self.live) {
            let ctx = rec.part(Part::Fluid);
            if let Some(b) = self.grid.record_weights(ctx, f) {
                l.record_extract(ctx, b);
            }
        }
        None
    }

    fn record_depth(&self, ctx: &mut FrameCtx, f: &SurfaceFrame, _: Option<Kernels>) -> Result<()> {
        if let (Some((params::Extraction::Gpu, _)), Some(l)) = (&self.path, &self.live) {
            return l.record_draw(ctx, f.frame, &f.targets.depth, f.targets.zbuffer.as_ref());
        }
        if let (Some((m, _)), Some(cast)) = (&self.bvh, &self.cast) {
            cast.record(ctx, f.frame, m, &f.targets.depth);
        }
        Ok(())
    }

    fn strays(&self) -> Option<(u64, usize)> {
        match self.path {
            Some((params::Extraction::Gpu, _)) => self.grid.strays(),
            _ => None,
        }
    }

    fn outgrown(&self) -> bool {
        matches!(self.path, Some((params::Extraction::Gpu, _))) && self.live.as_ref().is_some_and(|l| l.outgrown())
    }

    fn memory(&self) -> Vec<(&str, u64)> {
        self.live.as_ref().map(|l| l.memory()).unwrap_or_default()
    }
}

/// How [`reconstruct`] meshes particles (`meniscus mesh`, the Python package's `reconstruct_surface`).
#[derive(Clone, Copy, Debug)]
pub struct Reconstruct {
    /// Kernel support (world units): splashsurf's 2 × smoothing length × particle radius.
    pub support: f32,
    /// The lattice, iso value, field and path.
    pub extract: extract::ExtractParams,
    /// Laplacian smoothing afterwards.
    pub smoothing: smooth::SmoothParams,
}

/// Where [`reconstruct`]'s time went and what it left out.
#[derive(Clone, Debug)]
pub struct ReconstructReport {
    /// Particles left out as strays (far from the fluid).
    pub strays: usize,
    /// Seconds for the grid and each particle's 1/n_j (host).
    pub field_s: f64,
    /// The CPU extraction's times (block path), or the GPU's stages.
    pub extraction: ExtractionStats,
    /// Seconds the smoothing took.
    pub smooth_s: f64,
}

/// How the mesh was extracted.
#[derive(Clone, Debug)]
pub enum ExtractionStats {
    /// On the CPU (times of the block path, when it ran).
    Cpu(Option<extract::blocks::ExtractTimes>),
    /// On the GPU (the `mc` pass).
    Gpu(crate::compute::mc::McStats),
}

/// The iso surface of `positions` as a triangle mesh: strays left out (`scene::without_strays`), the field's
/// grid, the lattice and memory checked against the machine before anything large is allocated, marching
/// cubes on the CPU (rayon, the current pool) or with `gpu` on the device, then the smoothing.
pub fn reconstruct(
    positions: &[[f32; 3]],
    r: &Reconstruct,
    gpu: Option<(&std::sync::Arc<crate::gpu::Gpu>, &crate::compute::mc::Mc)>,
) -> Result<(extract::TriMesh, ReconstructReport)> {
    reconstruct_field(positions, r, gpu).map(|x| (x.mesh, x.report))
}

/// [`reconstruct`]'s mesh with the field it was made of, for what the exporters derive from it: velocities at
/// the vertices, the level set and the fog volume (`crate::field::export`).
pub struct Reconstructed {
    /// The mesh.
    pub mesh: extract::TriMesh,
    /// Where the time went.
    pub report: ReconstructReport,
    /// The field's grid (of the kept particles).
    pub grid: crate::field::iso::IsoGrid,
    /// 1 / n_j of the grid's sorted points.
    pub inv_n: Vec<f32>,
    /// The input index of each kept particle (None: all were kept).
    pub kept: Option<Vec<u32>>,
    /// How it was made.
    pub params: Reconstruct,
}

impl Reconstructed {
    /// The per-particle `values` (one per input particle, e.g. velocities) interpolated at the mesh's vertices.
    pub fn at_vertices(&self, values: &[[f32; 3]]) -> Vec<[f32; 3]> {
        crate::field::export::interpolate(&self.grid, &self.inv_n, values, self.kept.as_deref(), &self.mesh.vertices)
    }

    /// The surface as a narrow-band level set on the extraction's lattice, `half_width` voxels each side.
    pub fn level_set(&self, half_width: f32) -> crate::field::export::Volume {
        let e = &self.params.extract;
        crate::field::export::level_set(&self.grid, &self.inv_n, e.cube, e.threshold, half_width, &self.mesh.vertices)
    }

    /// The field as a fog volume on the extraction's lattice.
    pub fn fog(&self) -> crate::field::export::Volume {
        crate::field::export::fog(&self.grid, &self.inv_n, self.params.extract.cube)
    }

    /// Whether a world point is inside the surface (a level set's empty regions).
    pub fn inside(&self, x: glam::Vec3) -> bool {
        crate::field::export::inside(&self.grid, &self.inv_n, self.params.extract.threshold, x)
    }
}

/// [`reconstruct`], keeping the field ([`Reconstructed`]).
pub fn reconstruct_field(
    positions: &[[f32; 3]],
    r: &Reconstruct,
    gpu: Option<(&std::sync::Arc<crate::gpu::Gpu>, &crate::compute::mc::Mc)>,
) -> Result<Reconstructed> {
    let t0 = std::time::Instant::now();
    let (kept, strays) = crate::scene::kept_indices(positions, r.support);
    let kept_pos: std::borrow::Cow<[[f32; 3]]> = match &kept {
        Some(k) => k.iter().map(|&i| positions[i as usize]).collect::<Vec<_>>().into(),
        None => positions.into(),
    };
    let grid = crate::field::iso::IsoGrid::build(&kept_pos, r.support);
    extract::check_lattice(&grid, r.extract.cube)?;
    extract::check_memory(&grid, &r.extract, rayon::current_num_threads())?;
    let inv = grid.inv_density();
    let field_s = t0.elapsed().as_secs_f64();
    let (mut m, extraction) = match gpu {
        Some((gpu, mc)) => {
            let (m, st) = mc.extract(gpu, &grid, &inv, &r.extract)?;
            (m, ExtractionStats::Gpu(st))
        }
        None => {
            let (m, t) = extract::extract_timed(&grid, &inv, &r.extract);
            (m, ExtractionStats::Cpu(t))
        }
    };
    let t_smooth = std::time::Instant::now();
    // Smoothed where it was extracted: on the device its iterations and normals run there (the same mesh).
    match gpu {
        Some((gpu, mc)) => {
            mc.smooth(gpu, &mut m, &grid, &inv, &r.smoothing)?;
        }
        None => smooth::smooth(&mut m, &grid, &inv, &r.smoothing),
    }
    let report = ReconstructReport { strays, field_s, extraction, smooth_s: t_smooth.elapsed().as_secs_f64() };
    Ok(Reconstructed { mesh: m, report, grid, inv_n: inv, kept, params: *r })
}
