//! The mesh surface (`--preset smooth`): the marching-cubes mesh of the iso field (`extract`, on the CPU with
//! rayon; the `mc` pass is its GPU twin for `meniscus mesh --gpu`), optionally smoothed with splashsurf's
//! feature-weighted Laplacian (`smooth`), its BVH ray-cast per pixel by the `mesh` pass. It owns the mesh's
//! BVH and what it was made from; the CPU extracts again whenever the particles or the field change.

pub mod extract;
pub mod smooth;

use crate::error::Result;
use crate::frame::Recording;
use crate::gpu::FrameCtx;
use crate::passes::background::BvhBuffers;
use crate::renderer::upload_buffer;
use crate::scene::geometry::{Geometry, GpuBvh};

use super::{Kernels, Prepare, SurfaceFrame, Technique};

/// What a mesh is made from: [support, cube, threshold] in world units, the smoothing, the particles.
type MeshKey = ([f32; 3], smooth::SmoothParams, u64);

/// The mesh technique: the extracted mesh's BVH on the device.
#[derive(Default)]
pub struct FluidMesh {
    bvh: Option<(BvhBuffers, MeshKey)>,
    /// Seconds (CPU) the last extraction and BVH build took, and the mesh's vertex and triangle counts.
    stats: Option<(f64, usize, usize)>,
}

impl FluidMesh {
    /// Seconds the last extraction and BVH build took (CPU), and its vertex and triangle counts.
    pub fn stats(&self) -> Option<(f64, usize, usize)> {
        self.stats
    }
}

impl Technique for FluidMesh {
    /// Extract the iso-surface mesh of the current particles (spray and strays left out) with the `[iso]` field
    /// and the `[mesh]` cube size, and upload its BVH, unless it is there already.
    fn prepare(&mut self, p: &Prepare) -> Result<()> {
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
        let grid = super::iso::field::IsoGrid::build(&pts, field[0]);
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
        if let Some((m, _)) = &self.bvh {
            f.passes.mesh.record(ctx, f.frame, m, &f.targets.depth);
        }
        Ok(())
    }
}
