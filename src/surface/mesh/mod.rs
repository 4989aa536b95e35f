//! The mesh surface (`--preset smooth`): the marching-cubes mesh of the iso field (`extract`, on the CPU with
//! rayon; the `mc` pass is its GPU twin for `meniscus mesh --gpu`), optionally smoothed with splashsurf's
//! feature-weighted Laplacian (`smooth`), its BVH ray-cast per pixel by the `mesh` pass. It owns the mesh's
//! BVH and what it was made from; the CPU extracts again whenever the particles or the field change. Its files:
//! this one, [`params`] (the `[mesh]` section), [`cast`] (the `mesh` pass), its shader in shaders_glsl/mesh/.

pub mod cast;
pub mod params;

use crate::error::Result;
use crate::field::{extract, smooth};
use crate::gpu::recording::Recording;
use crate::gpu::transfer::upload_buffer;
use crate::gpu::FrameCtx;
use crate::passes::background::BvhBuffers;
use crate::scene::geometry::{Geometry, GpuBvh};

use super::{Kernels, Prepare, SurfaceFrame, Technique};

/// What a mesh is made from: [support, cube, threshold] in world units, the smoothing, the particles.
type MeshKey = ([f32; 3], smooth::SmoothParams, u64);

/// The mesh technique: the extracted mesh's BVH on the device.
#[derive(Default)]
pub struct FluidMesh {
    bvh: Option<(BvhBuffers, MeshKey)>,
    /// The `mesh` pass, built on the first prepare.
    cast: Option<cast::MeshCast>,
    /// Seconds (CPU) the last extraction and BVH build took, and the mesh's vertex and triangle counts.
    stats: Option<(f64, usize, usize)>,
}

impl FluidMesh {
    /// Seconds its last host build took, and the mesh's vertex and triangle counts, once built.
    pub fn mesh_stats(&self) -> Option<(f64, usize, usize)> {
        self.stats
    }
}

impl Technique for FluidMesh {
    /// Extract the iso-surface mesh of the current particles (isolated particles and strays left out) with the `[iso]` field
    /// and the `[mesh]` cube size, and upload its BVH, unless it is there already.
    fn prepare(&mut self, p: &Prepare) -> Result<()> {
        if self.cast.is_none() {
            self.cast = Some(cast::MeshCast::new(p.gpu)?);
        }
        let s = p.settings;
        let smoothing = smooth::SmoothParams {
            iterations: s.mesh.smoothing_iters,
            weights: s.mesh.smoothing_weights,
            ..Default::default()
        };
        let field = [s.iso.support * s.radius, s.mesh.cube * s.radius, s.iso.threshold];
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

    fn record_kernels<'a>(&'a self, _: &mut Recording, _: &SurfaceFrame<'a>) -> Option<Kernels<'a>> {
        None
    }

    fn record_depth(&self, ctx: &mut FrameCtx, f: &SurfaceFrame, _: Option<Kernels>) -> Result<()> {
        if let (Some((m, _)), Some(cast)) = (&self.bvh, &self.cast) {
            cast.record(ctx, f.frame, m, &f.targets.depth);
        }
        Ok(())
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
    pub extraction: Extraction,
    /// Seconds the smoothing took.
    pub smooth_s: f64,
}

/// How the mesh was extracted.
#[derive(Clone, Debug)]
pub enum Extraction {
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
            (m, Extraction::Gpu(st))
        }
        None => {
            let (m, t) = extract::extract_timed(&grid, &inv, &r.extract);
            (m, Extraction::Cpu(t))
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
