//! The live mesh surface (`[mesh] extraction = "gpu"`): the marching-cubes mesh of the SPH colour field
//! extracted on the GPU inside the frame whenever the particles change, and drawn by a raster pass from the
//! device's own buffers — no CPU extraction, no read-back, so GPU-written particles (`demo --sim --surface
//! mesh`) are meshed every step. The mesh is the one `meniscus mesh --gpu` writes (the `mc` pass, Janisz §2.2,
//! over the CPU block extraction's lattice and blocks: src/compute/mc.rs), with the host's parts moved onto the
//! device:
//! 1. the grid and weights 1/n_j: the renderer's particle grid (`super::super::grid`, `iso_density`);
//! 2. `mc_blocks`: the occupied blocks marked by the particles, numbered by a scan, listed in key order, and the
//!    next stages' indirect dispatches (mc_blocks.comp; the CPU's `occupied_blocks` is its reference);
//! 3. `mc_field`, `mc_count`, `mc_scan`, `mc_emit`: the `mc` pass's stages, their block count and capacities
//!    read from the device (the MC_LIVE variants);
//! 4. `mesh`: the triangles drawn by vertex pulling with an indirect draw into the fluid depth, reversed-Z
//!    depth test before the fragment shader (early depth; shaders_glsl/mesh/mesh_raster.{vert,frag}).
//!
//! The buffers are sized on the host before the frame: the blocks by the host's count of the blocks the
//! particles occupy (the same marking; for GPU-written particles a quarter of their number), the triangles and
//! vertices for a share of those blocks' cubes; the device writes what it needed (`MeshWork`), and a
//! frame that needed more draws what fit, says so ([`LiveMesh::outgrown`]), and the next prepare grows them.
//! In: the particle grid (weighted points, cells), the frame. Out: the fluid depth; the work counts.

use std::cell::Cell;
use std::sync::Arc;

use ash::vk;
use glam::{IVec3, Vec3};
use gpu_allocator::MemoryLocation;

use crate::compute::grid::{record_scan, ScanPush, SCAN};
use crate::compute::mc::{table_words, McPush};
use crate::compute::smooth::{SmoothPush, NEIGHBOURS};
use crate::compute::{device_buffer, groups_2d};
use crate::declare_program;
use crate::error::{Error, Result};
use crate::field::smooth::SmoothParams;
use crate::gpu::{Access, Buffer, ComputeProgram, FrameCtx, Gpu, GraphicsProgram, RasterTargets, Use};
use crate::shader_constants::{LOCAL_1D, MC_BLOCK, SCAN_BLOCK};
use crate::shaders;
use crate::surface::grid::IsoBuffers;
use crate::work::MeshWork;

/// The draw's pass name: the pass that writes the mesh into the fluid depth is `mesh` either way (ray cast or
/// raster), so timings compare by one key.
pub const NAME: &str = super::cast::NAME;
/// The block search's pass name (mc_blocks.comp); the other stages keep the `mc` pass's names.
pub const BLOCKS_NAME: &str = "mc_blocks";

// Mark: points → flags. List: flags, numbers → blocks, Live, args. Args: counts, starts, vertex counts and
// starts, Live → draw args, stats.
declare_program!(pub MARK: McPush = compute(shaders::MC_BLOCKS_MARK, [BufRead, BufWrite]));
declare_program!(pub LIST: McPush = compute(shaders::MC_BLOCKS_LIST, [BufRead, BufRead, BufWrite, BufWrite, BufWrite]));
declare_program!(pub ARGS: McPush = compute(shaders::MC_BLOCKS_ARGS, [BufRead, BufRead, BufRead, BufRead, BufRead, BufWrite, BufWrite, BufWrite]));
// The `mc` stages with the block count and capacities from Live: field (weighted points, cells, Live, blocks →
// field), count (field, blocks, table → counts, vertex counts; Live), emit (field, blocks, table, starts →
// positions, normals, triangles; Live).
declare_program!(pub FIELD: McPush = compute(shaders::MC_FIELD_LIVE, [BufRead, BufRead, BufRead, BufRead, BufWrite]));
declare_program!(pub COUNT: McPush = compute(shaders::MC_COUNT_LIVE, [BufRead, BufRead, BufRead, BufWrite, BufWrite, BufRead]));
declare_program!(pub EMIT: McPush = compute(shaders::MC_EMIT_LIVE, [BufRead, BufRead, BufRead, BufRead, BufRead, BufWrite, BufWrite, BufWrite, BufRead]));
// The smoothing (mesh_smooth.comp's LIVE variants, `compute::smooth`'s passes with the counts from LiveN, the last
// slot): weights (points, cells, weighted points as 1/n_j, c_j, positions → weights), count (triangles → counts),
// fill (triangles, starts → fill, triangle runs, neighbour runs), sort (starts, counts → runs sorted, ranges),
// an iteration (positions, ranges, neighbour runs, weights → positions).
declare_program!(pub SMOOTH_WEIGHTS: SmoothPush = compute(shaders::MESH_SMOOTH_WEIGHTS_LIVE, [BufRead, BufRead, BufRead, BufRead, BufRead, BufWrite, BufRead]));
declare_program!(pub SMOOTH_COUNT: SmoothPush = compute(shaders::MESH_SMOOTH_COUNT_LIVE, [BufRead, BufWrite, BufRead]));
declare_program!(pub SMOOTH_FILL: SmoothPush = compute(shaders::MESH_SMOOTH_FILL_LIVE, [BufRead, BufRead, BufWrite, BufWrite, BufWrite, BufRead]));
declare_program!(pub SMOOTH_SORT: SmoothPush = compute(shaders::MESH_SMOOTH_SORT_LIVE, [BufRead, BufRead, BufWrite, BufWrite, BufWrite, BufRead]));
declare_program!(pub SMOOTH_ITERATE: SmoothPush = compute(shaders::MESH_SMOOTH_LIVE, [BufRead, BufRead, BufRead, BufRead, BufWrite, BufRead]));
// The draw: frame, positions, triangles.
declare_program!(pub RASTER: Push = graphics(shaders::MESH_RASTER_VERT, shaders::MESH_RASTER_FRAG, [Uniform, BufRead, BufRead]));

/// Push constants of mesh_raster.vert.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Push {
    /// The fluid depth image in pixels.
    pub size: [f32; 2],
    /// Vertices the position buffer holds.
    pub vert_cap: u32,
}

/// The marching-cubes lattice of the live mesh: the CPU's `Lattice::of` over the grid's box (the particles'
/// box grown by the support), so on host-held particles the two paths extract the same mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
struct LiveLattice {
    lo: Vec3,
    h: f32,
    dims: IVec3,
    /// Blocks per axis.
    nb: IVec3,
    /// The support in cubes (a particle's reach in the block marking).
    reach: i32,
    support: f32,
    threshold: f32,
}

impl LiveLattice {
    fn new(lo: Vec3, hi: Vec3, support: f32, cube: f32, threshold: f32) -> Result<LiveLattice> {
        let (lo, hi) = (lo - support, hi + support);
        let d = ((hi - lo) / cube).ceil() + 1.0;
        if !d.is_finite() || d.max_element() > 1.0e6 || d.min_element() < 1.0 {
            return Err(Error::Invalid(format!(
                "mesh: a lattice of {d} corners (cube {cube}) over the fluid's box {lo} … {hi} is out of range"
            )));
        }
        let dims = d.as_ivec3();
        let b = MC_BLOCK as i32;
        Ok(LiveLattice {
            lo,
            h: cube,
            dims,
            nb: (dims - 1 + b - 1) / b,
            reach: (support / cube).ceil() as i32,
            support,
            threshold,
        })
    }

    fn all_blocks(&self) -> u64 {
        self.nb.x as u64 * self.nb.y as u64 * self.nb.z as u64
    }

    /// The `mc` stages' push constants over grid `g`.
    fn push(&self, g: &IsoBuffers) -> McPush {
        let (o, d) = (g.shape.origin, g.shape.dims);
        McPush {
            lat: [self.lo.x, self.lo.y, self.lo.z, self.h],
            grid: o,
            gdims: [d[0], d[1], d[2], 0],
            ldims: [self.dims.x, self.dims.y, self.dims.z, 0],
            field: [self.support, 1.0 / self.support, self.threshold, 0.0],
        }
    }
}

/// How many blocks, triangles and vertices the buffers hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Caps {
    blocks: u32,
    tris: u32,
    verts: u32,
}

impl Caps {
    /// Bytes of device memory per block held (field, four per-cube counts, the block's corner, its flag and
    /// number).
    const BLOCK_BYTES: u64 = 4 * ((MC_BLOCK + 3) as u64).pow(3) + 16 * (MC_BLOCK as u64).pow(3) + 16 + 8;

    fn cubes(&self) -> u64 {
        self.blocks as u64 * (MC_BLOCK as u64).pow(3)
    }

    fn bytes(&self) -> u64 {
        self.blocks as u64 * Self::BLOCK_BYTES + 12 * self.tris as u64 + 24 * self.verts as u64
    }
}

/// The buffers of one capacity.
struct LiveBuffers {
    /// Blocks of the lattice the flags cover.
    all_blocks: u32,
    caps: Caps,
    flags: Buffer,
    numbers: Buffer,
    block_sums: Buffer,
    blocks: Buffer,
    live: Buffer,
    /// Indirect commands: mc_field's dispatch (bytes 0–11), mc_count's and mc_emit's (16–27), the draw (32–47),
    /// the smoothing's per vertex (48–59) and per triangle (64–75).
    args: Buffer,
    /// The triangles and vertices extracted (at most the capacities), for the smoothing's shaders.
    live_n: Buffer,
    field: Buffer,
    counts: Buffer,
    start: Buffer,
    vcounts: Buffer,
    vstart: Buffer,
    sums: Buffer,
    pos: Buffer,
    nrm: Buffer,
    tri: Buffer,
    /// Blocks needed, triangles, vertices, outgrown (host-visible, written by mc_blocks' ARGS).
    stats: Buffer,
}

impl LiveBuffers {
    fn new(gpu: &Arc<Gpu>, all_blocks: u32, caps: Caps) -> Result<LiveBuffers> {
        let b = |name: &str, bytes: u64| device_buffer(gpu, name, bytes);
        let cubes = caps.cubes();
        let nc = ((MC_BLOCK + 3) as u64).pow(3);
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST;
        Ok(LiveBuffers {
            all_blocks,
            caps,
            flags: b("mesh_live_flags", 4 * all_blocks as u64)?,
            numbers: b("mesh_live_numbers", 4 * all_blocks as u64)?,
            block_sums: b("mesh_live_block_sums", 4 * (all_blocks as u64).div_ceil(SCAN_BLOCK as u64))?,
            blocks: b("mesh_live_blocks", 16 * caps.blocks as u64)?,
            live: b("mesh_live_header", 16)?,
            live_n: b("mesh_live_counts_n", 16)?,
            args: Buffer::new(
                gpu,
                "mesh_live_args",
                80,
                usage | vk::BufferUsageFlags::INDIRECT_BUFFER,
                MemoryLocation::GpuOnly,
            )?,
            field: b("mesh_live_field", 4 * nc * caps.blocks as u64)?,
            counts: b("mesh_live_counts", 4 * cubes)?,
            start: b("mesh_live_start", 4 * cubes)?,
            vcounts: b("mesh_live_vcounts", 4 * cubes)?,
            vstart: b("mesh_live_vstart", 4 * cubes)?,
            sums: b("mesh_live_sums", 4 * cubes.div_ceil(SCAN_BLOCK as u64))?,
            pos: b("mesh_live_positions", 12 * caps.verts as u64)?,
            nrm: b("mesh_live_normals", 12 * caps.verts as u64)?,
            tri: b("mesh_live_triangles", 12 * caps.tris as u64)?,
            stats: {
                let mut s = Buffer::new(gpu, "mesh_live_stats", 16, usage, MemoryLocation::GpuToCpu)?;
                s.write(0, &[0; 16])?;
                s
            },
        })
    }
}

/// The smoothing's buffers for the capacities of a [`LiveBuffers`] and `points` particles.
struct SmoothBuffers {
    caps: Caps,
    points: u32,
    /// Each particle's neighbour count c_j.
    c: Buffer,
    weights: Buffer,
    counts: Buffer,
    starts: Buffer,
    fill: Buffer,
    sums: Buffer,
    tri_runs: Buffer,
    nbr_runs: Buffer,
    ranges: Buffer,
    /// The iterations' second position buffer (odd iterations end here).
    pos2: Buffer,
}

impl SmoothBuffers {
    fn new(gpu: &Arc<Gpu>, caps: Caps, points: u32) -> Result<SmoothBuffers> {
        let b = |name: &str, bytes: u64| device_buffer(gpu, name, bytes);
        let (nv, corners) = (caps.verts as u64, 3 * caps.tris as u64);
        Ok(SmoothBuffers {
            caps,
            points,
            c: b("mesh_live_smooth_c", 4 * points as u64)?,
            weights: b("mesh_live_smooth_weights", 4 * nv)?,
            counts: b("mesh_live_smooth_counts", 4 * nv)?,
            starts: b("mesh_live_smooth_starts", 4 * nv)?,
            fill: b("mesh_live_smooth_fill", 4 * nv)?,
            sums: b("mesh_live_smooth_sums", 4 * nv.div_ceil(SCAN_BLOCK as u64))?,
            tri_runs: b("mesh_live_smooth_tri_runs", 4 * corners)?,
            nbr_runs: b("mesh_live_smooth_nbr_runs", 8 * corners)?,
            ranges: b("mesh_live_smooth_ranges", 8 * nv)?,
            pos2: b("mesh_live_smooth_positions", 12 * nv)?,
        })
    }

    fn bytes(&self) -> u64 {
        4 * self.points as u64 + 36 * self.caps.verts as u64 + 36 * self.caps.tris as u64
    }
}

/// The smoothing's programs.
struct SmoothPrograms {
    neighbours: ComputeProgram<SmoothPush>,
    weights: ComputeProgram<SmoothPush>,
    count: ComputeProgram<SmoothPush>,
    fill: ComputeProgram<SmoothPush>,
    sort: ComputeProgram<SmoothPush>,
    iterate: ComputeProgram<SmoothPush>,
}

/// The live mesh: its programs, the case table, its buffers, the lattice they were made for.
pub struct LiveMesh {
    mark: ComputeProgram<McPush>,
    list: ComputeProgram<McPush>,
    args: ComputeProgram<McPush>,
    field: ComputeProgram<McPush>,
    count: ComputeProgram<McPush>,
    emit: ComputeProgram<McPush>,
    scan: ComputeProgram<ScanPush>,
    raster: GraphicsProgram<Push>,
    smoothing: SmoothPrograms,
    table: Buffer,
    bufs: Option<LiveBuffers>,
    /// The smoothing's buffers, while the mesh is smoothed.
    smooth_bufs: Option<SmoothBuffers>,
    /// The smoothing of this frame (`[mesh] smoothing_iters`, `smoothing_weights`), set by `prepare`.
    smooth: SmoothParams,
    /// The lattice, the smoothing and the grid generation the buffers hold the mesh of.
    extracted: Option<(LiveLattice, SmoothParams, u64)>,
    /// The lattice of this frame, set by `prepare`.
    lattice: Option<LiveLattice>,
    /// The next frame extracts again (the particles, the lattice or the capacities changed).
    stale: Cell<bool>,
}

/// Device memory the live mesh may take before its capacities stop at what fits.
const BUDGET: u64 = 2 << 30;

impl LiveMesh {
    /// Build the programs and upload the case table.
    pub fn new(gpu: &Arc<Gpu>) -> Result<LiveMesh> {
        let targets = RasterTargets {
            color_format: vk::Format::R32_SFLOAT,
            depth_format: Some(vk::Format::D32_SFLOAT),
            min_blend: false,
            topology: vk::PrimitiveTopology::TRIANGLE_LIST,
        };
        Ok(LiveMesh {
            mark: ComputeProgram::new(gpu, &MARK)?,
            list: ComputeProgram::new(gpu, &LIST)?,
            args: ComputeProgram::new(gpu, &ARGS)?,
            field: ComputeProgram::new(gpu, &FIELD)?,
            count: ComputeProgram::new(gpu, &COUNT)?,
            emit: ComputeProgram::new(gpu, &EMIT)?,
            scan: ComputeProgram::new(gpu, &SCAN)?,
            raster: GraphicsProgram::new(gpu, &RASTER, targets)?,
            smoothing: SmoothPrograms {
                neighbours: ComputeProgram::new(gpu, &NEIGHBOURS)?,
                weights: ComputeProgram::new(gpu, &SMOOTH_WEIGHTS)?,
                count: ComputeProgram::new(gpu, &SMOOTH_COUNT)?,
                fill: ComputeProgram::new(gpu, &SMOOTH_FILL)?,
                sort: ComputeProgram::new(gpu, &SMOOTH_SORT)?,
                iterate: ComputeProgram::new(gpu, &SMOOTH_ITERATE)?,
            },
            table: crate::gpu::transfer::upload_buffer(
                gpu,
                "mesh_live_table",
                bytemuck::cast_slice(&table_words()),
                None,
            )?,
            bufs: None,
            smooth_bufs: None,
            smooth: SmoothParams::default(),
            extracted: None,
            lattice: None,
            stale: Cell::new(true),
        })
    }

    /// Before a frame: the lattice over the grid's box `(lo, hi)` for `support`, `cube` and `threshold` (world
    /// units); the buffers made or grown (after the frames that read them) when the lattice has more blocks, or
    /// the latest frame needed more than they hold; the next frame extracts when any of that or the grid's
    /// particles (`generation`) changed.
    pub fn prepare(
        &mut self,
        p: &super::super::Prepare,
        (lo, hi): (Vec3, Vec3),
        (support, cube, threshold): (f32, f32, f32),
        smooth: SmoothParams,
        (generation, points): (u64, u32),
        triangles_per_cube: f32,
    ) -> Result<()> {
        let lat = LiveLattice::new(lo, hi, support, cube, threshold)?;
        let all = lat.all_blocks();
        if all > u32::MAX as u64 / (MC_BLOCK as u64).pow(3) {
            return Err(Error::Limit(format!("mesh: a lattice of {all} blocks is more than the live mesh can number")));
        }
        let all = all as u32;
        let room = |x: u32| x.saturating_add(x / 4);
        // The blocks the particles occupy: counted on the host where it holds them (the same marking as
        // mc_blocks'), else a quarter of the particles (eight fill a block of a liquid's interior), grown when a
        // frame needs more.
        let particles = p.particles;
        let want = if particles.gpu_written() {
            (particles.count() / 4).max(1024)
        } else {
            let lattice = crate::field::extract::Lattice { lo: lat.lo, h: lat.h, dims: lat.dims };
            let pts = particles.surface_positions();
            room(crate::field::extract::blocks::occupied_count_of(&pts, &lattice, support, MC_BLOCK as i32) as u32)
        }
        .clamp(1, all.max(1));
        let need = self.bufs.as_ref().and_then(|b| Self::needed(b).ok().flatten());
        let grow = match &self.bufs {
            None => true,
            Some(b) => b.all_blocks < all || b.caps.blocks < want || need.is_some(),
        };
        if grow {
            let old = self.bufs.as_ref().map(|b| b.caps);
            let caps = Self::caps(p.gpu, want, triangles_per_cube, old, need)?;
            let gpu = p.gpu;
            p.executor.replace(&mut self.bufs, || LiveBuffers::new(gpu, room(all), caps).map(Some))?;
            self.extracted = None;
        }
        // The smoothing's buffers follow the mesh's capacities and the particles.
        let caps = self.bufs.as_ref().map(|b| b.caps);
        let fits = |s: &SmoothBuffers| Some(s.caps) == caps && s.points >= points;
        if smooth.iterations == 0 {
            self.smooth_bufs = None;
        } else if let (false, Some(caps)) = (self.smooth_bufs.as_ref().is_some_and(fits), caps) {
            let gpu = p.gpu;
            let points = points.saturating_add(points / 4).max(1);
            p.executor.replace(&mut self.smooth_bufs, || SmoothBuffers::new(gpu, caps, points).map(Some))?;
            self.extracted = None;
        }
        if self.extracted != Some((lat, smooth, generation)) {
            self.stale.set(true);
            self.extracted = Some((lat, smooth, generation));
        }
        self.smooth = smooth;
        self.lattice = Some(lat);
        Ok(())
    }

    /// What the latest frame's extraction needed beyond the buffers (blocks, triangles, vertices), if anything.
    fn needed(b: &LiveBuffers) -> Result<Option<Caps>> {
        let w = Self::stats_words(b)?;
        Ok((w[3] != 0).then_some(Caps { blocks: w[0], tris: w[1], verts: w[2] }))
    }

    fn stats_words(b: &LiveBuffers) -> Result<[u32; 4]> {
        let bytes = b.stats.read()?;
        let w: &[u32] = bytemuck::try_cast_slice(&bytes[..16]).map_err(|e| Error::Invalid(format!("mesh: {e}")))?;
        Ok([w[0], w[1], w[2], w[3]])
    }

    /// The capacities for `blocks` occupied blocks (or what `need` said, with a quarter to spare): triangles for
    /// `per_cube` of their cubes and vertices for half as many (`[mesh] live_triangles_per_cube`, a sixth; the
    /// 6,859 dam break at 0.5 r: 0.088 triangles and 0.044 vertices per cube of its occupied blocks), never fewer
    /// than before, within [`BUDGET`] and the device's buffer range.
    fn caps(gpu: &Gpu, blocks: u32, per_cube: f32, old: Option<Caps>, need: Option<Caps>) -> Result<Caps> {
        let room = |x: u32| x.saturating_add(x / 4);
        let per = (MC_BLOCK * MC_BLOCK * MC_BLOCK) as u64;
        let mut c = Caps { blocks: blocks.max(1), tris: 0, verts: 0 };
        if let Some(n) = need {
            c.blocks = c.blocks.max(room(n.blocks));
        }
        let cubes = (c.blocks as u64 * per) as f64;
        c.tris = (cubes * per_cube as f64).clamp(1.0, u32::MAX as f64) as u32;
        c.verts = (cubes * per_cube as f64 / 2.0).clamp(1.0, u32::MAX as f64) as u32;
        if let Some(o) = old {
            c.tris = c.tris.max(o.tris);
            c.verts = c.verts.max(o.verts);
        }
        if let Some(n) = need {
            c.tris = c.tris.max(room(n.tris));
            c.verts = c.verts.max(room(n.verts));
        }
        let range = gpu.info.max_storage_buffer_range;
        let field = 4 * ((MC_BLOCK + 3) as u64).pow(3) * c.blocks as u64;
        if field > range || 4 * c.cubes() > range {
            return Err(Error::Limit(format!(
                "mesh: the live mesh of {} occupied blocks needs a field of {} MiB, more than this device's storage \
                 buffer range ({} MiB): use a larger [mesh] cube or extraction = \"cpu\"",
                c.blocks,
                field >> 20,
                range >> 20
            )));
        }
        // Triangles and vertices within the buffer range and the budget (never below what a frame needed).
        let floor = need.unwrap_or(Caps { blocks: 0, tris: 0, verts: 0 });
        let left = BUDGET.saturating_sub(c.blocks as u64 * Caps::BLOCK_BYTES);
        let scale = (left as f64 / (12.0 * c.tris as f64 + 24.0 * c.verts as f64)).min(1.0);
        c.tris = ((c.tris as f64 * scale) as u32).min((range / 12) as u32).max(room(floor.tris));
        c.verts = ((c.verts as f64 * scale) as u32).min((range / 12) as u32).max(room(floor.verts));
        if 12 * c.tris as u64 > range || 12 * c.verts as u64 > range {
            return Err(Error::Limit(format!(
                "mesh: the live mesh of {} triangles and {} vertices is more than this device's storage buffer \
                 range holds ({} MiB): use a larger [mesh] cube or extraction = \"cpu\"",
                floor.tris,
                floor.verts,
                range >> 20
            )));
        }
        Ok(c)
    }

    /// Record the extraction of the particles in grid `g` when they (or the lattice) changed since the last
    /// extraction: the occupied blocks, the field, the counts and their scans, the vertices and triangles.
    pub fn record_extract(&self, ctx: &mut FrameCtx, g: &IsoBuffers) {
        let (Some(b), Some(lat)) = (&self.bufs, &self.lattice) else { return };
        if !self.stale.replace(false) {
            return;
        }
        let n = g.shape.dims[3];
        let push = lat.push(g);
        let cubes = b.caps.cubes() as u32;
        ctx.pass(BLOCKS_NAME, |ctx| {
            ctx.fill(&b.flags, 0);
            let mark = McPush {
                gdims: [lat.nb.x as u32, lat.nb.y as u32, lat.nb.z as u32, n],
                field: [lat.reach as f32, 0.0, 0.0, 0.0],
                ..push
            };
            self.mark.dispatch(ctx, &[(&g.weighted).into(), (&b.flags).into()], &mark, groups_2d(n.div_ceil(LOCAL_1D)));
            record_scan(&self.scan, ctx, (&b.flags, &b.numbers, &b.block_sums), b.all_blocks);
            let list = McPush {
                gdims: [lat.nb.x as u32, lat.nb.y as u32, lat.nb.z as u32, lat.all_blocks() as u32],
                field: [0.0, f32::from_bits(b.caps.blocks), f32::from_bits(b.caps.tris), f32::from_bits(b.caps.verts)],
                ..push
            };
            let res = [(&b.flags).into(), (&b.numbers).into(), (&b.blocks).into(), (&b.live).into(), (&b.args).into()];
            self.list.dispatch(ctx, &res, &list, groups_2d((lat.all_blocks() as u32).div_ceil(LOCAL_1D)));
        });
        ctx.pass("mc_field", |ctx| {
            let res =
                [(&g.weighted).into(), (&g.cells).into(), (&b.live).into(), (&b.blocks).into(), (&b.field).into()];
            self.field.dispatch_indirect(ctx, &res, &push, &b.args, 0);
        });
        ctx.pass("mc_count", |ctx| {
            ctx.fill(&b.counts, 0);
            ctx.fill(&b.vcounts, 0);
            let res = [
                (&b.field).into(),
                (&b.blocks).into(),
                (&self.table).into(),
                (&b.counts).into(),
                (&b.vcounts).into(),
                (&b.live).into(),
            ];
            self.count.dispatch_indirect(ctx, &res, &push, &b.args, 16);
        });
        ctx.pass("mc_scan", |ctx| {
            for (c, st) in [(&b.counts, &b.start), (&b.vcounts, &b.vstart)] {
                record_scan(&self.scan, ctx, (c, st, &b.sums), cubes);
            }
            let args = McPush { gdims: [0, 0, 0, cubes], ..push };
            let res = [
                (&b.counts).into(),
                (&b.start).into(),
                (&b.vcounts).into(),
                (&b.vstart).into(),
                (&b.live).into(),
                (&b.args).into(),
                (&b.stats).into(),
                (&b.live_n).into(),
            ];
            self.args.dispatch(ctx, &res, &args, [1, 1, 1]);
            ctx.barrier(&[Use::Buffer(&b.stats, Access::HostRead)]);
        });
        ctx.pass("mc_emit", |ctx| {
            let res = [
                (&b.field).into(),
                (&b.blocks).into(),
                (&self.table).into(),
                (&b.start).into(),
                (&b.vstart).into(),
                (&b.pos).into(),
                (&b.nrm).into(),
                (&b.tri).into(),
                (&b.live).into(),
            ];
            self.emit.dispatch_indirect(ctx, &res, &push, &b.args, 16);
        });
        if let Some(sb) = self.smooth_bufs.as_ref().filter(|_| self.smooth.iterations > 0) {
            self.record_smooth(ctx, g, b, sb);
        }
    }

    /// The smoothing of the extracted mesh (`compute::smooth`'s passes, the counts from the device): each
    /// particle's neighbour count, each vertex's feature weight, the vertices' neighbours, the Jacobi iterations
    /// (ending in `pos` after an even count, `pos2` after an odd one).
    fn record_smooth(&self, ctx: &mut FrameCtx, g: &IsoBuffers, b: &LiveBuffers, sb: &SmoothBuffers) {
        let (p, sm) = (&self.smooth, &self.smoothing);
        let (o, d) = (g.shape.origin, g.shape.dims);
        let push = |n: u32, which: u32| SmoothPush {
            n: [n, which, 0, 0],
            grid: o,
            gdims: [d[0], d[1], d[2], 0],
            field: [g.shape.support(), p.normalization, 0.0, 0.0],
        };
        let (pv, pt) = (push(b.caps.verts, 1), push(b.caps.tris, 0));
        let (vargs, targs) = (48, 64);
        ctx.pass("mesh_smooth/weights", |ctx| {
            if p.weights {
                let np = d[3];
                let res = [(&g.weighted).into(), (&g.cells).into(), (&sb.c).into()];
                sm.neighbours.dispatch(ctx, &res, &push(np, 0), groups_2d(np.div_ceil(LOCAL_1D)));
                let res = [
                    (&g.weighted).into(),
                    (&g.cells).into(),
                    (&g.weighted).into(),
                    (&sb.c).into(),
                    (&b.pos).into(),
                    (&sb.weights).into(),
                    (&b.live_n).into(),
                ];
                sm.weights.dispatch_indirect(ctx, &res, &pv, &b.args, vargs);
            } else {
                ctx.fill(&sb.weights, 1f32.to_bits());
            }
        });
        ctx.pass("mesh_smooth/adjacency", |ctx| {
            ctx.fill(&sb.counts, 0);
            ctx.fill(&sb.fill, 0);
            sm.count.dispatch_indirect(
                ctx,
                &[(&b.tri).into(), (&sb.counts).into(), (&b.live_n).into()],
                &pt,
                &b.args,
                targs,
            );
            record_scan(&self.scan, ctx, (&sb.counts, &sb.starts, &sb.sums), b.caps.verts);
            let res = [
                (&b.tri).into(),
                (&sb.starts).into(),
                (&sb.fill).into(),
                (&sb.tri_runs).into(),
                (&sb.nbr_runs).into(),
                (&b.live_n).into(),
            ];
            sm.fill.dispatch_indirect(ctx, &res, &pt, &b.args, targs);
            let res = [
                (&sb.starts).into(),
                (&sb.counts).into(),
                (&sb.tri_runs).into(),
                (&sb.nbr_runs).into(),
                (&sb.ranges).into(),
                (&b.live_n).into(),
            ];
            sm.sort.dispatch_indirect(ctx, &res, &pv, &b.args, vargs);
        });
        ctx.pass(crate::compute::smooth::NAME, |ctx| {
            let pos = [&b.pos, &sb.pos2];
            for k in 0..p.iterations as usize {
                let (src, dst) = (pos[k % 2], pos[(k + 1) % 2]);
                let res = [
                    src.into(),
                    (&sb.ranges).into(),
                    (&sb.nbr_runs).into(),
                    (&sb.weights).into(),
                    dst.into(),
                    (&b.live_n).into(),
                ];
                sm.iterate.dispatch_indirect(ctx, &res, &pv, &b.args, vargs);
            }
        });
    }

    /// Record the `mesh` pass: the extracted triangles into `depth` (linear eye depth, +inf where none) with the
    /// depth buffer `zbuffer`.
    pub fn record_draw(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        depth: &crate::gpu::Image,
        zbuffer: Option<&crate::gpu::Image>,
    ) -> Result<()> {
        let Some(b) = &self.bufs else { return Ok(()) };
        let z = zbuffer
            .ok_or_else(|| Error::Invalid("mesh: the live mesh surface needs the frame's depth buffer".into()))?;
        let push = Push { size: [depth.extent.width as f32, depth.extent.height as f32], vert_cap: b.caps.verts };
        // After an odd number of smoothing iterations the positions are in the second buffer.
        let pos = match &self.smooth_bufs {
            Some(sb) if self.smooth.iterations % 2 == 1 => &sb.pos2,
            _ => &b.pos,
        };
        ctx.pass(NAME, |ctx| {
            let res = [frame.into(), pos.into(), (&b.tri).into()];
            self.raster.draw_indirect(ctx, &res, &push, (depth, f32::INFINITY, Some(z)), &b.args, 32);
        });
        Ok(())
    }

    /// The latest extraction's work, read from the device (after its frame finished).
    pub fn work(&self) -> Option<MeshWork> {
        let b = self.bufs.as_ref()?;
        let w = Self::stats_words(b).ok()?;
        let blocks = (w[0] as u64).min(b.caps.blocks as u64);
        Some(MeshWork {
            blocks,
            cubes: blocks * (MC_BLOCK as u64).pow(3),
            field_samples: blocks * ((MC_BLOCK + 3) as u64).pow(3),
            triangles: w[1] as u64,
            vertices: w[2] as u64,
            outgrown: w[3] != 0,
        })
    }

    /// The latest frame's mesh did not fit its buffers (read after the frame finished): the next prepare grows
    /// them and extracts again.
    pub fn outgrown(&self) -> bool {
        self.work().is_some_and(|w| w.outgrown)
    }

    /// (name, bytes) of its buffers.
    pub fn memory(&self) -> Vec<(&str, u64)> {
        let smooth = self.smooth_bufs.as_ref().map_or(0, |s| s.bytes());
        self.bufs.as_ref().map(|b| vec![("mesh_live", b.caps.bytes() + smooth)]).unwrap_or_default()
    }
}
