//! The `iso_volume` pass and its lattice (`[iso] smoothing` > 0): the SPH field blurred in 3D where the water is
//! calm, on a sparse lattice of bricks where the particles reach — its brick table, the pool of allocated
//! bricks and their sums, the deposit's work counts; its programs (shaders_glsl/iso/iso_volume.comp: the
//! bricks marked, allocated, the sums deposited, the aprons copied), recorded when the particles or the
//! parameters changed; and the pool's sizing on the host. The field itself is defined by
//! `crate::field::volume` (its CPU reference: `VolumeShape::{marked, deposit, sample}`).
//! In: the grid's weighted points and neighbour counts. Out: the lattice the `iso` cast reads (`iso_vol.comp`).
use std::sync::Arc;

use ash::vk;

use crate::declare_program;
use crate::error::Result;
use crate::field::volume::{VolumeParams, VolumeShape};
use crate::gpu::{Buffer, ComputeProgram, FrameCtx, Gpu};
use crate::passes::LOCAL_1D;
use crate::shaders;
use crate::surface::grid::{IsoBuffers, IsoPush};
use crate::surface::Prepare;

/// The pass's one name (shader stem, debug label, timestamp key, JSON key): `iso_volume`, recorded when the
/// particles or `[iso] smoothing`, `bulk` or `voxel` changed.
pub const NAME: &str = "iso_volume";

/// The smoothed iso field on its sparse lattice (`iso_volume`), read by the volume cast.
pub struct IsoVolume {
    /// The lattice.
    pub shape: VolumeShape,
    /// Bricks the pool holds.
    pub capacity: u32,
    /// Per brick of the box: 0, or its pool index + 1 (R32UI texels).
    pub table: Buffer,
    /// {0, 1, 1, bricks}: the bricks allocated.
    pub header: Buffer,
    /// The allocated bricks' coordinates, packed (R32UI texels).
    pub coords: Buffer,
    /// Two fixed-point sums per stored voxel of the pool (10³ per brick: its 8³ and an apron), (B, B c̄): the
    /// field the cast reads (RG32UI texels).
    pub acc: Buffer,
    /// The deposit's work counts: [0] point–voxel deposits ([`IsoVolume::work`]).
    pub work: crate::work::Counters,
    /// Whether the deposit takes one 64-bit atomic per deposit (else two 32-bit ones).
    pub deposit64: bool,
    /// The parameters and the grid's generation (`IsoBuffers::generation`) the sums were deposited for
    /// (`None`: stale).
    pub built_for: std::cell::Cell<Option<(VolumeParams, u64)>>,
}

impl IsoVolume {
    /// Buffers for the lattice `shape` with a pool of `capacity` bricks.
    pub fn new(gpu: &Arc<Gpu>, shape: VolumeShape, capacity: u32) -> Result<IsoVolume> {
        let voxels = capacity.max(1) as u64 * crate::field::volume::STORED_BRICK_VOXELS as u64;
        let limit = gpu.info.max_storage_buffer_range.min(gpu.info.max_texel_buffer_elements * 8);
        if 8 * voxels > limit {
            return Err(crate::error::Error::Limit(format!(
                "the smoothed iso field needs {capacity} bricks of {b}³ voxels ({} MiB of sums with their aprons), more than this \
                 device's largest buffer ({} MiB): set [iso] voxel larger (now {:.4} world units) or smoothing = 0 \
                 (--preset quality: the exact field, no lattice)",
                (8 * voxels) >> 20,
                limit >> 20,
                shape.spacing,
                b = crate::field::volume::BRICK
            )));
        }
        // TRANSFER_DST: zeroed before each build; TRANSFER_SRC: the tests read the field back.
        use vk::BufferUsageFlags as U;
        let usage = U::STORAGE_BUFFER | U::TRANSFER_DST | U::TRANSFER_SRC;
        let table = shape.table_len() as u64;
        Ok(IsoVolume {
            shape,
            capacity,
            table: Buffer::texels(gpu, "iso_volume_table", 4 * table, usage, vk::Format::R32_UINT)?,
            header: Buffer::texels(gpu, "iso_volume_header", 16, usage, vk::Format::R32_UINT)?,
            coords: Buffer::texels(gpu, "iso_volume_coords", 4 * capacity.max(1) as u64, usage, vk::Format::R32_UINT)?,
            acc: Buffer::texels(gpu, "iso_volume_acc", 8 * voxels, usage, vk::Format::R32G32_UINT)?,
            work: crate::work::Counters::new(gpu, "iso_volume_work")?,
            deposit64: gpu.info.int64_atomics,
            built_for: std::cell::Cell::new(None),
        })
    }

    /// The last build's deposit (waits for the device: for `bench` and tests, after a frame that built it).
    pub fn work(&self, gpu: &Arc<Gpu>) -> Result<crate::work::IsoVolumeWork> {
        let [deposits, ..] = self.work.read(gpu)?;
        Ok(crate::work::IsoVolumeWork { deposits, atomics: if self.deposit64 { deposits } else { 2 * deposits } })
    }

    /// Whether these buffers hold the lattice `shape` with `bricks` allocated.
    pub fn fits(&self, shape: &VolumeShape, bricks: u32) -> bool {
        self.table.size >= 4 * shape.table_len() as u64 && self.capacity >= bricks
    }

    /// `push` with this lattice in `aniso` (origin, spacing), `aniso2.yzw` (bricks per axis) and `volume` (the
    /// bulk ramp), as iso_field.glsl reads it.
    pub fn push(&self, push: IsoPush, p: &VolumeParams) -> IsoPush {
        let (o, b) = (self.shape.origin, self.shape.bricks);
        IsoPush {
            aniso: [o.x, o.y, o.z, self.shape.spacing],
            aniso2: [0.0, b[0] as f32, b[1] as f32, b[2] as f32],
            volume: [p.bulk[0], p.bulk[1], p.gradient_bound(), self.shape.empty_reach()],
            ..push
        }
    }

    /// The push constants of iso_volume.comp for `points` points.
    pub fn vol_push(&self, p: &VolumeParams, points: u32) -> VolPush {
        let (o, b, s) = (self.shape.origin, self.shape.bricks, self.shape.spacing);
        let [r0, r1] = p.deposit_radii();
        VolPush {
            origin: [o.x, o.y, o.z, self.shape.spacing],
            bdims: [b[0], b[1], b[2], self.capacity],
            params: [p.deposit_scale(r0), r0 / s, self.shape.taps as f32, r1 / s],
            misc: [points, 0, 0, 0],
        }
    }
}

/// Push constants of iso_volume.comp.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct VolPush {
    /// xyz: voxel (0, 0, 0), w: spacing (world units).
    pub origin: [f32; 4],
    /// xyz: bricks per axis, w: the pool's capacity (bricks).
    pub bdims: [u32; 4],
    /// x: the deposit's scale I_W h³ / (0.6383 R³) of the least ordered point, y: its R (voxels), z: ⌈R⌉ of
    /// the widest, w: the most ordered point's R (voxels).
    pub params: [f32; 4],
    /// x: points.
    pub misc: [u32; 4],
}

// The smoothed field: the weighted points mark the bricks they need in the table; the marked bricks take pool
// indices (the header counts them, their coordinates listed); the points deposit their sums (integer atomics).
declare_program!(pub VOLUME_MARK: VolPush = compute(shaders::ISO_VOLUME_MARK, [Uniform, TexelRead, BufWrite]));
declare_program!(pub VOLUME_ALLOC: VolPush = compute(shaders::ISO_VOLUME_ALLOC, [Uniform, BufWrite, BufWrite, BufWrite]));
declare_program!(pub VOLUME: VolPush = compute(shaders::ISO_VOLUME, [Uniform, TexelRead, TexelRead, TexelRead, BufWrite, BufWrite]));
// The same deposit with one 64-bit atomic per voxel (devices with shaderBufferInt64Atomics: `DeviceInfo::int64_atomics`).
declare_program!(pub VOLUME_DEPOSIT64: VolPush = compute(shaders::ISO_VOLUME_DEPOSIT64, [Uniform, TexelRead, TexelRead, TexelRead, BufWrite, BufWrite]));
// Each allocated brick's apron copied from its neighbours.
declare_program!(pub VOLUME_APRON: VolPush = compute(shaders::ISO_VOLUME_APRON, [Uniform, TexelRead, TexelRead, TexelRead, BufWrite]));

/// The `iso_volume` pass's programs: mark, allocate, deposit (two 32-bit atomics, or one 64-bit where the device
/// has them), apron.
pub struct VolumePrograms([ComputeProgram<VolPush>; 4]);

impl VolumePrograms {
    /// Build the programs.
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(VolumePrograms([
            ComputeProgram::new(gpu, &VOLUME_MARK)?,
            ComputeProgram::new(gpu, &VOLUME_ALLOC)?,
            ComputeProgram::new(gpu, if gpu.info.int64_atomics { &VOLUME_DEPOSIT64 } else { &VOLUME })?,
            ComputeProgram::new(gpu, &VOLUME_APRON)?,
        ]))
    }

    /// When the smoothed field `v` of grid `b` is stale for `p` (new particles or parameters): `iso_volume` (the bricks
    /// marked and allocated, the sums deposited), with its own timestamp. Like the weights, the field depends
    /// on the particles alone: a static set builds it once.
    pub fn record(&self, ctx: &mut FrameCtx, frame: &Buffer, b: &IsoBuffers, v: &IsoVolume, p: &VolumeParams) {
        let key = (*p, b.generation.get());
        if v.built_for.get() == Some(key) {
            return;
        }
        v.built_for.set(Some(key));
        let n = b.shape.dims[3];
        let per_point = [n.div_ceil(LOCAL_1D), 1, 1];
        ctx.pass(NAME, |ctx| {
            ctx.part("iso_volume/clear", |ctx| {
                ctx.fill(&v.table, 0);
                ctx.fill(&v.header, 0);
                ctx.fill(&v.acc, 0);
                ctx.fill(&v.work.buffer, 0);
            });
            let push = v.vol_push(p, n);
            let mark = [frame.into(), (&b.weighted).into(), (&v.table).into()];
            ctx.part("iso_volume/mark", |ctx| self.0[0].dispatch(ctx, &mark, &push, per_point));
            let table = [(v.shape.table_len() as u32).div_ceil(LOCAL_1D), 1, 1];
            let alloc = [frame.into(), (&v.table).into(), (&v.header).into(), (&v.coords).into()];
            ctx.part("iso_volume/alloc", |ctx| self.0[1].dispatch(ctx, &alloc, &push, table));
            let (weighted, counts, table, acc, work) = (&b.weighted, &b.counts, &v.table, &v.acc, &v.work.buffer);
            let dep = [frame.into(), weighted.into(), counts.into(), table.into(), acc.into(), work.into()];
            ctx.part("iso_volume/deposit", |ctx| self.0[2].dispatch(ctx, &dep, &push, per_point));
            let apron = [frame.into(), (&v.table).into(), (&v.coords).into(), (&v.header).into(), (&v.acc).into()];
            let stored = v.capacity as u64 * crate::field::volume::STORED_BRICK_VOXELS as u64;
            let groups = [stored.div_ceil(LOCAL_1D as u64) as u32, 1, 1];
            ctx.part("iso_volume/apron", |ctx| self.0[3].dispatch(ctx, &apron, &push, groups));
        });
    }
}

/// The smoothed field's sparse lattice for grid `b`'s box, when `[iso] smoothing` asks for it (`params`): its
/// pool sized for the bricks the particles need (counted here by the rule iso_volume marks them with, so memory
/// follows the water, not the box; particles written on the GPU, whose positions the host does not have, get
/// every brick of their box), (re)allocated when the box or the count outgrows it (its field is then stale);
/// dropped when smoothing is off.
pub fn ensure(slot: &mut Option<IsoVolume>, b: &IsoBuffers, p: &Prepare, params: Option<VolumeParams>) -> Result<()> {
    let Some(params) = params else {
        if slot.is_some() {
            p.executor.wait_idle()?;
            *slot = None;
        }
        return Ok(());
    };
    let (o, d) = (b.shape.origin, b.shape.dims);
    let shape =
        crate::surface::grid::volume_shape(o, [d[0], d[1], d[2]], &params).map_err(crate::error::Error::Limit)?;
    let fresh = |v: &IsoVolume| v.shape == shape && v.built_for.get() == Some((params, b.generation.get()));
    if slot.as_ref().is_some_and(fresh) {
        return Ok(());
    }
    let ahead = p.particles.analysis().and_then(|a| a.volume).filter(|(s, _)| *s == shape);
    let bricks = if p.particles.is_external() {
        shape.table_len() as u32
    } else if let Some((_, bricks)) = ahead {
        bricks
    } else {
        crate::surface::grid::marked_bricks(&shape, p.particles.positions())
    };
    // A sequence's box and bricks change every frame: the buffers are kept while they hold the new lattice
    // (its field is rebuilt for the new particles anyway), and grow by a quarter when they do not.
    if let Some(v) = slot.as_mut().filter(|v| v.fits(&shape, bricks)) {
        v.shape = shape;
        v.built_for.set(None);
        return Ok(());
    }
    p.executor.wait_idle()?;
    *slot = None;
    let spare = if p.particles.is_external() { bricks } else { bricks + bricks / 4 };
    let mut table = shape;
    // The table too gets a quarter to spare (its box moves with the water).
    table.bricks = shape.bricks.map(|n| n + n / 8);
    let mut v = IsoVolume::new(p.gpu, table, spare.max(1))?;
    v.shape = shape;
    *slot = Some(v);
    Ok(())
}
