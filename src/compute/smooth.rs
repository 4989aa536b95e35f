//! `mesh_smooth` pass: Laplacian smoothing with feature weights and area-weighted vertex normals of an extracted
//! mesh on the GPU — the GPU form of src/field/smooth.rs (splashsurf's finishing step, `[mesh] smoothing_iters`),
//! so `meniscus mesh --gpu` with smoothing (`--preset smooth`) iterates on the device. The host gives the device
//! what the CPU reference computes before its iterations — each vertex's edge neighbours (sorted, unique), its
//! feature weight and its incident triangles in ascending order — and the iterations and the normals run there
//! (shaders_glsl/mesh_smooth.comp), each in the CPU's order of additions: the result equals the CPU's within the
//! floats' rounding (tests/gpu_passes.rs, `gpu_mesh_smoothing_matches_the_cpu`).
use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::declare_program;
use crate::error::Result;
use crate::field::extract::TriMesh;
use crate::field::iso::IsoGrid;
use crate::field::smooth::{feature_weights, vertex_neighbours, SmoothParams};
use crate::gpu::transfer::{host_vec, read_back, upload_buffer};
use crate::gpu::{Buffer, ComputeProgram, FrameCtx, Gpu, Timer};
use crate::shader_constants::LOCAL_1D;
use crate::shaders;
use crate::timing::PassTimes;

/// The pass's one name (module, shader stem, timestamp key).
pub const NAME: &str = "mesh_smooth";

/// Push constants (SmoothPush in mesh_smooth.comp).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SmoothPush {
    /// Vertices.
    pub n: u32,
}

// An iteration: positions, neighbour offsets, neighbours, weights → the next positions.
declare_program!(pub ITERATE: SmoothPush = compute(shaders::MESH_SMOOTH, [BufRead, BufRead, BufRead, BufRead, BufWrite]));
// Normals: positions, triangle offsets, incident triangles, triangles → normals.
declare_program!(pub NORMALS: SmoothPush = compute(shaders::MESH_SMOOTH_NORMALS, [BufRead, BufRead, BufRead, BufRead, BufWrite]));

/// The pass's programs.
pub struct GpuSmooth {
    iterate: ComputeProgram<SmoothPush>,
    normals: ComputeProgram<SmoothPush>,
}

/// Each vertex's incident triangles in ascending order, as offsets into one list (a counting sort: the
/// triangles are visited in order, so each run comes out sorted) — the order the CPU adds their normals in.
pub fn vertex_triangles(m: &TriMesh) -> (Vec<u32>, Vec<u32>) {
    let n = m.vertices.len();
    let mut offsets = vec![0u32; n + 1];
    for t in &m.triangles {
        for &v in t {
            offsets[v as usize + 1] += 1;
        }
    }
    for i in 0..n {
        offsets[i + 1] += offsets[i];
    }
    let mut fill: Vec<u32> = offsets[..n].to_vec();
    let mut list = vec![0u32; offsets[n] as usize];
    for (k, t) in m.triangles.iter().enumerate() {
        for &v in t {
            list[fill[v as usize] as usize] = k as u32;
            fill[v as usize] += 1;
        }
    }
    (offsets, list)
}

fn groups(n: u32) -> [u32; 3] {
    let g = n.div_ceil(LOCAL_1D).max(1);
    let x = g.min(32_768);
    [x, g.div_ceil(x), 1]
}

impl GpuSmooth {
    /// Build the pipelines.
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(GpuSmooth { iterate: ComputeProgram::new(gpu, &ITERATE)?, normals: ComputeProgram::new(gpu, &NORMALS)? })
    }

    /// Smooth `m` in place as [`crate::field::smooth::smooth`] does (`grid` and `inv_n`: the particles it was
    /// extracted from, for the feature weights), the iterations and the normals on the GPU. Returns the GPU
    /// time per stage (`mesh_smooth`: the iterations; `mesh_smooth/normals`).
    pub fn smooth(
        &self,
        gpu: &Arc<Gpu>,
        m: &mut TriMesh,
        grid: &IsoGrid,
        inv_n: &[f32],
        p: &SmoothParams,
    ) -> Result<PassTimes> {
        if p.iterations == 0 || m.vertices.is_empty() {
            return Ok(PassTimes::default());
        }
        let (offsets, nbrs) = vertex_neighbours(m);
        let weights =
            if p.weights { feature_weights(m, grid, inv_n, p.normalization) } else { vec![1.0; m.vertices.len()] };
        let (toff, tlist) = vertex_triangles(m);
        let up = |name: &str, data: &[u8]| upload_buffer(gpu, name, data, None);
        let bytes = 12 * m.vertices.len() as u64;
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::TRANSFER_SRC
            | vk::BufferUsageFlags::TRANSFER_DST;
        let scratch = |name: &str| Buffer::new(gpu, name, bytes.max(16), usage, MemoryLocation::GpuOnly);
        // Both position buffers readable back (the last iteration may end in either).
        let first = upload_buffer(
            gpu,
            "mesh_smooth_pos",
            bytemuck::cast_slice(&m.vertices),
            Some(scratch("mesh_smooth_pos")?),
        )?;
        let pos = [first, scratch("mesh_smooth_pos2")?];
        let (off, nb, wts) = (
            up("mesh_smooth_offsets", bytemuck::cast_slice(&offsets))?,
            up("mesh_smooth_neighbours", bytemuck::cast_slice(&nbrs))?,
            up("mesh_smooth_weights", bytemuck::cast_slice(&weights))?,
        );
        let (toff, tlist) = (
            up("mesh_smooth_tri_offsets", bytemuck::cast_slice(&toff))?,
            up("mesh_smooth_tri_list", bytemuck::cast_slice(&tlist))?,
        );
        let tris = up("mesh_smooth_tris", bytemuck::cast_slice(&m.triangles))?;
        let nrm = scratch("mesh_smooth_normals")?;
        let push = SmoothPush { n: m.vertices.len() as u32 };
        let g = groups(push.n);
        let iterations = p.iterations as usize;
        let mut timer = Timer::new(gpu)?;
        gpu.one_shot(|cmd| {
            let mut ctx = FrameCtx::new(gpu, cmd, Some(&mut timer));
            ctx.pass(NAME, |ctx| {
                for k in 0..iterations {
                    let (src, dst) = (&pos[k % 2], &pos[(k + 1) % 2]);
                    let res = [src.into(), (&off).into(), (&nb).into(), (&wts).into(), dst.into()];
                    self.iterate.dispatch(ctx, &res, &push, g);
                }
            });
            ctx.pass("mesh_smooth/normals", |ctx| {
                let res =
                    [(&pos[iterations % 2]).into(), (&toff).into(), (&tlist).into(), (&tris).into(), (&nrm).into()];
                self.normals.dispatch(ctx, &res, &push, g);
            });
            Ok(())
        })?;
        let times = timer.read()?;
        let back = read_back(gpu, &[(&pos[iterations % 2], 0, bytes), (&nrm, 0, bytes)])?;
        let n = m.vertices.len();
        m.vertices = bytemuck::pod_collect_to_vec(&host_vec::<f32>(&back[0], 3 * n)?);
        m.normals = bytemuck::pod_collect_to_vec(&host_vec::<f32>(&back[1], 3 * n)?);
        Ok(times)
    }
}
