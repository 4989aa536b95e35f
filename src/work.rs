//! What a pass did, counted on the device: beside its time, the measure of a change's GPU cost that every
//! device gives alike (lavapipe's milliseconds do not follow a GPU's; these counts do). The `noise` pass counts
//! its own work ([`NoiseWork`]), so do `splat` ([`SplatWork`]: sphere–pixel tests), `iso` ([`IsoWork`]: field
//! samples, rays queued), `iso_volume` ([`IsoVolumeWork`]: deposits and their atomics) and the live mesh's `mc`
//! stages ([`MeshWork`]: blocks, cubes, field samples, triangles); `meniscus bench` reports them (JSON
//! `noise_work`, `splat_work`, `iso_work`, `iso_volume_work`, `mesh_work`) beside every pass's compute
//! invocations (the GPU timer's pipeline-statistics queries, `crate::gpu::timer`).

use std::sync::Arc;

use crate::error::Result;
use crate::gpu::{Buffer, Gpu};

/// A pass's counters on the device: [`Counters::WORDS`] u32 its shader adds to (the pass zeroes them when it is
/// recorded, `FrameCtx::fill`), read back after the frame. Owned by the pass's resources (`Targets::splat_work`,
/// the iso queue's, the smoothed field's).
pub struct Counters {
    /// The words (storage; zeroed and read back by transfers).
    pub buffer: Buffer,
}

impl Counters {
    /// Words a pass may count in.
    pub const WORDS: usize = 4;

    /// Zeroed-on-record counters named `name` (the GPU memory report's name).
    pub fn new(gpu: &Arc<Gpu>, name: &str) -> Result<Counters> {
        use ash::vk::BufferUsageFlags as U;
        let usage = U::STORAGE_BUFFER | U::TRANSFER_DST | U::TRANSFER_SRC;
        let bytes = 4 * Self::WORDS as u64;
        Ok(Counters { buffer: Buffer::new(gpu, name, bytes, usage, gpu_allocator::MemoryLocation::GpuOnly)? })
    }

    /// The words as the last frame that recorded the pass left them (waits for the device).
    pub fn read(&self, gpu: &Arc<Gpu>) -> Result<[u64; Counters::WORDS]> {
        let host = crate::gpu::transfer::read_back(gpu, &[(&self.buffer, 0, 4 * Self::WORDS as u64)])?;
        Self::words(&host[0])
    }

    /// The words of a read-back copy of the counters.
    pub fn words(host: &Buffer) -> Result<[u64; Counters::WORDS]> {
        let w: Vec<u32> = crate::gpu::transfer::host_vec(host, Self::WORDS)?;
        Ok(std::array::from_fn(|k| w[k] as u64))
    }
}

/// The `iso` pass's work in one frame that its queue counts: the rays its first dispatch left unfinished
/// (after `[iso] first_steps` samples) for the second to finish, and the coarse-to-fine cast's fallbacks
/// (`surface::iso::queue::IsoQueue::work`). The second dispatch's cost follows the first count and how far those rays
/// march.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct IsoWork {
    /// Rays queued by the first dispatch.
    pub queued: u64,
    /// Rays the coarse-to-fine cast queued to march from their start.
    pub fallbacks: u64,
    /// Tiles (LOCAL_2D × LOCAL_2D pixels) of the bound spheres' depth that held fluid: the first dispatch's work
    /// groups (0 with coarse-to-fine, which dispatches every block).
    pub tiles: u64,
    /// Field samples (evaluations of φ) over the pass's dispatches: the march's steps, the bisections and
    /// Newton steps, each lane's of the wide dispatch — the pass's cost on any device follows this count.
    pub samples: u64,
}

/// The compute `splat` pass's work in one frame (`Targets::splat_work`; the rasterised variants count none).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct SplatWork {
    /// Sphere–pixel tests (a ray–sphere or ray–ellipsoid intersection each): the pixels of every drawn sphere's
    /// screen rectangle, less the tiles the occlusion bound skipped.
    pub tests: u64,
    /// Spheres drawn (on screen and not hidden in every tile they touch).
    pub spheres: u64,
    /// 8×8 tiles a sphere skipped because `splat_cull`'s occlusion bound hid it there.
    pub tiles_skipped: u64,
}

/// The `iso_volume` pass's deposit in one frame (it runs only when the particles change).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct IsoVolumeWork {
    /// Point–voxel deposits (voxels within a point's deposit radius, on the lattice).
    pub deposits: u64,
    /// Atomics they took: one 64-bit atomic per deposit where the device has them, else two 32-bit ones.
    pub atomics: u64,
}

/// The `noise` pass's work in one frame, as its counters hold it (`passes::noise::NoiseTargets::work`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct NoiseWork {
    /// The coarsest accumulator level any sprite was evaluated on (0: every sprite at full resolution).
    pub level: u32,
    /// Sprite texels visited (each sprite's rectangle at its level).
    pub texels: u64,
    /// Sprites drawn (not culled as too deep, behind the camera or off screen).
    pub sprites: u64,
    /// Texels whose noise was evaluated (inside the sprite's disc, on the fluid, not too deep).
    pub evaluated: u64,
    /// Sprites left out of the tiled splat (more than NOISE_MAX_TILES tiles: larger than the screen).
    pub skipped: u64,
    /// Tile-list entries of the tiled splat (sprites × the tiles each touches).
    pub binned: u64,
    /// The longest tile list of the tiled splat (sprites binned to one tile; noise_gather sums it in chunks of
    /// NOISE_CHUNK, one work group each).
    pub longest: u64,
}

/// Each pass's own count of its work in one frame (`RendererState::work`): a pass that did not run (or, for
/// `iso_volume`, did not rebuild the field) has none; nor has the splat in a rasterised variant.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct FrameWork {
    /// The compute `splat`.
    pub splat: Option<SplatWork>,
    /// `iso`.
    pub iso: Option<IsoWork>,
    /// `iso_volume` (the smoothed field's rebuild).
    pub iso_volume: Option<IsoVolumeWork>,
    /// `noise`.
    pub noise: Option<NoiseWork>,
    /// The live mesh surface's extraction (its latest: it runs when the particles change).
    pub mesh: Option<MeshWork>,
}

/// What the live extraction did in its latest frame, counted on the device: the measure of its cost that every
/// device gives alike (bench JSON `mesh_work`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct MeshWork {
    /// Occupied blocks of MC_BLOCK³ cubes.
    pub blocks: u64,
    /// Cubes visited (mc_count and mc_emit: MC_BLOCK³ per block).
    pub cubes: u64,
    /// Field samples (mc_field: (MC_BLOCK + 3)³ corners per block, each a gather over the neighbour cells).
    pub field_samples: u64,
    /// Triangles extracted (and drawn, when none was past the capacity).
    pub triangles: u64,
    /// Vertices extracted.
    pub vertices: u64,
    /// Whether a buffer was too small (the frame drew what fit; the next prepare grows them).
    pub outgrown: bool,
}
