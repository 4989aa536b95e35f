//! `noise` pass: the patent's surface detail (NVIDIA patent US 8,947,430, eq. 15–17). Every
//! particle splats a Gaussian sprite of per-particle 3D noise, weighted by its depth below the fluid surface and
//! scaled by how fast its velocity changes, into a noise image N (level 0 of its accumulator atlas, fixed
//! point); the `normals` pass adds N's partial derivatives to the normals (small waves: the atlas is the noise
//! effect's detail height field, `crate::layer::Detail`) and the composite tints the surface toward
//! grey-white whitecaps by N's magnitude (its `tint` layer reads the same image). Runs on every surface (after the
//! fluid's depth, before `normals`, so the normals and the reflections see the waves); `[noise] enabled = false`
//! leaves it out. Shaders: shaders_glsl/noise_cull.comp, noise_args.comp and noise.comp (the splat on CPU
//! drivers; noise_bin, noise_scan, noise_fill and noise_gather on GPUs), shaders_glsl/noise_resolve.comp (N where
//! coarse levels were written), with shaders_glsl/noise.glsl (the kernel, mirrored by [`reference`]).
use std::sync::Arc;

use ash::vk;

use crate::compute::clear::Clear;
use crate::declare_program;
use crate::error::Result;
use crate::gpu::{groups_2d, Buffer, ComputeProgram, FrameCtx, Gpu, Image};
use crate::shaders;
use crate::work::NoiseWork;

/// The pass's one name (module, shader stem, debug label, timestamp key, JSON key): `noise`.
pub const NAME: &str = "noise";

/// Fixed-point units of the accumulator per particle radius of height (a detail height field's:
/// [`crate::layer::DETAIL_UNITS`]).
pub const UNITS: f32 = crate::layer::DETAIL_UNITS;

/// Settings of the `noise` pass: the `[noise]` section of a settings file. Lengths in particle radii.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Waves and whitecaps on the surface (false: the pass is not recorded and nothing is tinted).
    pub enabled: bool,
    /// Sprite radius around each particle (radii).
    pub size: f32,
    /// Noise cycles across a sprite's radius.
    pub frequency: f32,
    /// Depth below the surface (radii) over which a particle's weight falls by 1/e (the patent's
    /// exp(−(depth below the surface)²)).
    pub falloff: f32,
    /// Height amplitude (radii) of a particle whose velocity changes slowly: still water's ripple.
    pub calm: f32,
    /// Height amplitude (radii) of a particle whose velocity changes faster than `threshold`.
    pub turbulent: f32,
    /// Change of velocity, |Δv| / Δt in world units per s², above which a particle is turbulent (eq. 17; the
    /// amplitude ramps from ½ to 1½ of it). About gravity's 9.81 m/s² for scenes in metres: the shared 59k dam
    /// break's particles change their velocity by 3 m/s² (median) to 10 m/s² (99th percentile) from one 25 fps
    /// frame to the next as it breaks; the live simulation's resting pool by at most 3.9 m/s² (its solver's
    /// jitter, low-passed over a frame). Scenes in other units scale it with them.
    pub threshold: f32,
    /// Scale of the noise's slopes added to the normals.
    pub strength: f32,
    /// Level of detail: a sprite is evaluated on the coarsest level of the accumulator (texels of 2^L pixels)
    /// that still samples its finer octave this many times per cycle, and interpolated from there (2 …
    /// NOISE_LOD_SAMPLES = 6). Fewer: fewer texels evaluated (a quarter per level) and softer small waves. At 4
    /// sprites from 12.8 px radius go to level 1 (19.2 px at 6): a close view of the 59k sequence at 1080p
    /// evaluates 3.5× fewer texels than at 6, and a close view of its frame 20 differs by 0.04 / 255 on average
    /// (0.08 % of pixels by more than 8 / 255); views whose sprites are smaller do not change.
    pub lod_samples: f32,
    /// |N| (radii) where the whitecaps' tint starts (`foam_from`: its deprecated spelling) …
    #[serde(alias = "foam_from")]
    pub whitecaps_from: f32,
    /// … and where it is full (`foam_full`).
    #[serde(alias = "foam_full")]
    pub whitecaps_full: f32,
    /// The full tint's weight (0: no whitecaps; `foam`).
    #[serde(alias = "foam")]
    pub whitecaps: f32,
    /// The whitecaps' colour, lit by the sun and the ambient light (`foam_color`).
    #[serde(alias = "foam_color")]
    pub whitecaps_color: [f32; 3],
}

impl Default for Params {
    fn default() -> Self {
        Params {
            enabled: true,
            size: 3.0,
            frequency: 0.8,
            falloff: 2.0,
            calm: 0.04,
            turbulent: 0.6,
            threshold: 10.0,
            strength: 1.0,
            lod_samples: 4.0,
            whitecaps_from: 0.12,
            whitecaps_full: 0.5,
            whitecaps: 0.85,
            whitecaps_color: [0.92, 0.94, 0.96],
        }
    }
}

impl crate::section::Section for Params {
    fn name(&self) -> &'static str {
        NAME
    }

    fn check(&self) -> crate::section::Checked {
        let k = crate::section::Keys(NAME);
        k.above("size", self.size, 0.0, 16.0)?;
        k.above("frequency", self.frequency, 0.0, 64.0)?;
        k.above("falloff", self.falloff, 0.0, 64.0)?;
        k.within("calm", self.calm, 0.0, 8.0)?;
        k.within("turbulent", self.turbulent, 0.0, 8.0)?;
        k.above("threshold", self.threshold, 0.0, 1e9)?;
        k.within("strength", self.strength, 0.0, 64.0)?;
        k.within("lod_samples", self.lod_samples, 2.0, crate::shader_constants::NOISE_LOD_SAMPLES as f32)?;
        k.within("whitecaps_from", self.whitecaps_from, 0.0, 64.0)?;
        k.above("whitecaps_full", self.whitecaps_full, 0.0, 64.0)?;
        k.rule("whitecaps_full", self.whitecaps_full > self.whitecaps_from, || {
            format!("whitecaps_full = {} must exceed whitecaps_from = {}", self.whitecaps_full, self.whitecaps_from)
        })?;
        k.within("whitecaps", self.whitecaps, 0.0, 1.0)?;
        k.each("whitecaps_color", &self.whitecaps_color, 0.0, 1.0)
    }
}

/// Push constants of the splat's shaders (shaders_glsl/noise_push.glsl: one declaration for all of them).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SpritePush {
    /// Particles (their motions follow the positions in the buffer).
    pub count: u32,
    /// [`Params::size`].
    pub size: f32,
    /// [`Params::frequency`].
    pub freq: f32,
    /// [`Params::falloff`].
    pub falloff: f32,
    /// [`Params::calm`].
    pub calm: f32,
    /// [`Params::turbulent`].
    pub turbulent: f32,
    /// [`Params::threshold`].
    pub threshold: f32,
    /// Tiles of every level of the atlas ([`tile_count`]; the tiled splat).
    pub tiles: u32,
    /// Sprites of at most this many texels are splatted with atomics rather than binned ([`SMALL_SPRITE`]).
    pub small: u32,
    /// [`Params::lod_samples`].
    pub lod: f32,
    /// noise_resolve's work groups (x, y): noise_scan (or noise_args) writes its indirect dispatch, none when the
    /// splat wrote level 0 alone.
    pub resolve: [u32; 2],
}

/// The tiled splat bins only sprites of more texels than this; smaller ones are splatted by their own thread
/// with atomics (a tile's work group tests every sprite of the tile at all its texels: worth it for a sprite
/// hundreds of texels across, not for one a few across). 64 against 16, 256 and 1,024 on an H100:
/// docs/surface-detail.md.
pub const SMALL_SPRITE: u32 = 64;

/// Whether this device splats the noise through tiles (noise_bin, noise_scan, noise_gather: each tile's texels
/// summed by one work group; sprites of at most 64 texels splatted by their own thread; the lists' fill and the
/// tiles' sums dispatched indirectly, not at all when nothing was binned) rather than one thread per sprite with
/// atomics (noise.comp). On a GPU the
/// per-sprite splat leaves warps idle behind large sprites and its atomics contend (1.05 ms of the 59k frame at
/// 1080p on an H100 for 5 M texels); on a CPU driver (lavapipe) a work group's lanes are SIMD lanes of one core,
/// where every thread of a tile testing every sprite of the tile costs more than the atomics it saves.
pub fn tiled(gpu: &Gpu) -> bool {
    !gpu.info.device_type.contains("CPU")
}

/// Tiles (NOISE_TILE² texels) of every level of a `width`×`height` output's atlas (noise.glsl's numbering).
pub fn tile_count(width: u32, height: u32) -> u32 {
    use crate::shader_constants::{NOISE_LEVELS, NOISE_TILE};
    (0..=NOISE_LEVELS)
        .map(|l| {
            let (w, h) = (width.div_ceil(1 << l), height.div_ceil(1 << l));
            w.div_ceil(NOISE_TILE) * h.div_ceil(NOISE_TILE)
        })
        .sum()
}

// The per-sprite splat (CPU drivers). Cull: frame, particles, fluid depth → work (the listed count, the
// coarsest level), the listed sprites' particle indices.
declare_program!(pub CULL: SpritePush = compute(shaders::NOISE_CULL, [Uniform, BufRead, ImgRead, BufWrite, BufWrite]));
// Splat, one thread per listed sprite: frame, particles (+ motions), fluid depth → accumulator atlas (cleared
// first), work counts; the listed indices.
declare_program!(pub SPLAT: SpritePush = compute(shaders::NOISE, [Uniform, BufRead, ImgRead, ImgWrite, BufWrite, BufRead]));
// The splat's and noise_resolve's dispatches: work (the listed count, the coarsest level) → args.
declare_program!(pub ARGS: SpritePush = compute(shaders::NOISE_ARGS, [BufRead, BufWrite]));
// The tiled splat: binning (count, then fill), the lists' starts, the tiles' sums.
// Bin: frame, particles, fluid depth → tiles (counts), sprite records, work, the small sprites' terms, the binned
// sprites' indices.
declare_program!(pub BIN: SpritePush = compute(shaders::NOISE_BIN, [Uniform, BufRead, ImgRead, BufWrite, BufWrite, BufWrite, ImgWrite, BufWrite]));
// Scan: tiles (counts → starts, cursors and first chunks), work → the fill's and the gather's indirect dispatches.
declare_program!(pub SCAN: SpritePush = compute(shaders::NOISE_SCAN, [BufWrite, BufRead, BufWrite]));
// Fill: sprite records, binned indices, work, fluid depth (its size) → tiles (cursors), lists.
declare_program!(pub FILL: SpritePush = compute(shaders::NOISE_FILL, [BufRead, BufRead, BufRead, ImgRead, BufWrite, BufWrite]));
// Gather: frame, sprite records, tiles, lists, fluid depth → accumulator atlas (cleared first), work.
declare_program!(pub GATHER: SpritePush = compute(shaders::NOISE_GATHER, [Uniform, BufRead, BufRead, BufRead, ImgRead, ImgWrite, BufWrite]));
// Resolve (only when the splat wrote coarser levels than 0): frame, accumulator atlas (level 0 rewritten with N,
// fixed point), fluid depth, the splat's work (its coarsest level).
declare_program!(pub RESOLVE: () = compute(shaders::NOISE_RESOLVE, [Uniform, ImgWrite, ImgRead, BufRead]));

/// How the sprites reach the accumulator.
enum Splat {
    /// The sprites that draw listed (noise_cull.comp), then one thread per listed sprite with atomics
    /// (noise.comp); noise_args writes the splat's and noise_resolve's dispatches between them.
    Alone(Box<SpriteSplat>),
    /// Binned to tiles, each tile summed by a work group (noise_bin, noise_scan, noise_gather).
    Tiled(Box<TiledSplat>),
}

/// The per-sprite splat's programs.
struct SpriteSplat {
    cull: ComputeProgram<SpritePush>,
    splat: ComputeProgram<SpritePush>,
    args: ComputeProgram<SpritePush>,
}

/// The tiled splat's programs.
struct TiledSplat {
    bin: ComputeProgram<SpritePush>,
    fill: ComputeProgram<SpritePush>,
    scan: ComputeProgram<SpritePush>,
    gather: ComputeProgram<SpritePush>,
}

/// The pass: its compute programs, built once per device.
pub struct Noise {
    splat: Splat,
    small: u32,
    /// How N reaches level 0: noise_resolve is dispatched indirectly, with work groups only when the splat
    /// wrote a coarser level than 0 (noise_scan, or noise_args after the per-sprite splat, writes the count), and
    /// writes N back over level 0's sums in their fixed point; the normals and the composite read level 0 either
    /// way (one full-screen dispatch fewer on most frames: an early return in each of its 32 k work groups at
    /// 1080p cost the H100 what resolving did, 0.023 ms; lavapipe's resolve cost 2.4 ms of a wave frame at
    /// 480×270).
    resolve: ComputeProgram<()>,
    /// The atlas's clear, each frame.
    clear: Clear,
}

/// The images the pass reads and writes.
pub struct NoiseImages<'a> {
    /// Fluid depth at full resolution.
    pub depth: &'a Image,
    /// The pass's own resources (the effect's images, allocated only while it is on).
    pub own: &'a NoiseTargets,
}

/// What the pass owns per frame size: the accumulator atlas (N at its level 0) and the work counts, and the
/// splat's lists, grown with the particle count ([`NoiseTargets::reserve`]): the per-sprite splat's listed
/// sprites, or the tiled splat's bins. Allocated only while `[noise] enabled` (`Targets::noise`).
pub struct NoiseTargets {
    /// Fixed-point accumulator atlas (R32_UINT): level 0 (the output's size) with the coarser levels stacked
    /// to its right ([`atlas_extent`]). Once the frame's pass has run, level 0 holds N ([`UNITS`] per radius,
    /// signed; 0 off the fluid): the normals' detail and the composite's layer.
    pub accum: Image,
    /// The splat's work, u32 ×8 ([`NoiseWork`]; host-readable).
    pub work: Buffer,
    /// The per-sprite splat's indirect dispatches (8 u32, noise_args writes them): noise_resolve's at 0 (none
    /// at level 0 alone), noise.comp's over the listed sprites at 16. The tiled splat's are in its bins' `args`.
    pub sprite_args: Buffer,
    /// The per-sprite splat's listed sprites (a particle index each; noise_cull appends), once reserved.
    pub listed: Option<Buffer>,
    /// The tiled splat's bins, once reserved.
    pub bins: Option<Bins>,
    width: u32,
    height: u32,
}

/// The tiled splat's buffers for up to `particles` particles.
pub struct Bins {
    /// Per particle: centre, R, z; offset, amplitude (2 vec4; written for the binned sprites).
    pub sprites: Buffer,
    /// Per tile: count, start, cursor, first chunk of noise_gather (4 u32 × [`tile_count`]).
    pub tiles: Buffer,
    /// The tiles' lists of particle indices: at most NOISE_MAX_TILES per particle.
    pub lists: Buffer,
    /// The binned sprites' particle indices (noise_bin appends, noise_fill reads).
    pub binned: Buffer,
    /// The indirect dispatches of noise_fill and noise_gather (none when nothing was binned) and noise_resolve
    /// (none at level 0 alone): noise_scan writes them.
    pub args: Buffer,
    /// Particles these buffers hold.
    pub particles: u32,
}

/// The accumulator atlas of a `width`×`height` output: level 0 plus [`crate::shader_constants::NOISE_LEVELS`]
/// coarser levels stacked in a column to its right (noise.glsl's `noise_level_base`).
pub fn atlas_extent(width: u32, height: u32) -> vk::Extent2D {
    let levels = crate::shader_constants::NOISE_LEVELS;
    let column: u32 = (1..=levels).map(|l| height.div_ceil(1 << l)).sum();
    vk::Extent2D { width: width + width.div_ceil(2), height: height.max(column) }
}

impl NoiseTargets {
    /// The pass's resources for a `width`×`height` output.
    pub fn new(gpu: &Arc<Gpu>, width: u32, height: u32) -> Result<NoiseTargets> {
        use vk::ImageUsageFlags as U;
        let storage = U::STORAGE | U::TRANSFER_SRC | U::TRANSFER_DST;
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST;
        Ok(NoiseTargets {
            accum: Image::new(gpu, "noise_accum", atlas_extent(width, height), vk::Format::R32_UINT, storage, None)?,
            work: Buffer::new(gpu, "noise_work", 32, usage, gpu_allocator::MemoryLocation::GpuToCpu)?,
            sprite_args: Buffer::new(
                gpu,
                "noise_sprite_args",
                32,
                usage | vk::BufferUsageFlags::INDIRECT_BUFFER,
                gpu_allocator::MemoryLocation::GpuOnly,
            )?,
            listed: None,
            bins: None,
            width,
            height,
        })
    }

    /// Whether [`NoiseTargets::reserve`] would allocate for `particles` (the caller waits for the GPU first).
    pub fn needs(&self, particles: u32, tiled: bool) -> bool {
        match tiled {
            true => self.bins.as_ref().is_none_or(|b| b.particles < particles),
            false => self.listed_capacity() < particles,
        }
    }

    /// The output's size (level 0 of the atlas).
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Particles the per-sprite splat's list holds.
    pub fn listed_capacity(&self) -> u32 {
        self.listed.as_ref().map_or(0, |b| (b.size / 4) as u32)
    }

    /// Make the splat's lists hold `particles` particles (with room for a quarter more, so a growing count does
    /// not reallocate every frame): the tiled splat's bins, or the per-sprite splat's list. The GPU must not be
    /// using the old ones.
    pub fn reserve(&mut self, gpu: &Arc<Gpu>, particles: u32, tiled: bool) -> Result<()> {
        if !self.needs(particles, tiled) {
            return Ok(());
        }
        let n = particles.max(1024).saturating_add(particles / 4);
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST;
        let gpu_only = gpu_allocator::MemoryLocation::GpuOnly;
        if !tiled {
            self.listed = None;
            self.listed = Some(Buffer::new(gpu, "noise_listed", 4 * n as u64, usage, gpu_only)?);
            return Ok(());
        }
        let tiles = tile_count(self.width, self.height) as u64;
        let max = crate::shader_constants::NOISE_MAX_TILES as u64;
        self.bins = None;
        self.bins = Some(Bins {
            sprites: Buffer::new(gpu, "noise_sprites", 32 * n as u64, usage, gpu_only)?,
            tiles: Buffer::new(gpu, "noise_tiles", 16 * tiles, usage, gpu_only)?,
            lists: Buffer::new(gpu, "noise_lists", 4 * max * n as u64, usage, gpu_only)?,
            binned: Buffer::new(gpu, "noise_binned", 4 * n as u64, usage, gpu_only)?,
            args: Buffer::new(gpu, "noise_args", 48, usage | vk::BufferUsageFlags::INDIRECT_BUFFER, gpu_only)?,
            particles: n,
        });
        Ok(())
    }

    /// The last recorded frame's work (read once its GPU work has finished).
    pub fn work(&self) -> Result<NoiseWork> {
        let b = self.work.read()?;
        let w = |k: usize| u32::from_le_bytes(b[4 * k..4 * k + 4].try_into().expect("4 bytes")) as u64;
        Ok(NoiseWork {
            level: w(0) as u32,
            texels: w(1),
            sprites: w(2),
            evaluated: w(3),
            skipped: w(4),
            binned: w(5),
            longest: w(7),
        })
    }

    /// (name, bytes) of each resource, for the memory table.
    pub fn memory(&self) -> Vec<(&str, u64)> {
        let mut m = vec![(self.accum.name.as_str(), self.accum.bytes()), (self.work.name.as_str(), self.work.size)];
        if let Some(b) = &self.listed {
            m.push((b.name.as_str(), b.size));
        }
        if let Some(b) = &self.bins {
            for buf in [&b.sprites, &b.tiles, &b.lists, &b.binned, &b.args] {
                m.push((buf.name.as_str(), buf.size));
            }
        }
        m
    }
}

impl Noise {
    /// Build the pass's pipelines (their slot lists were checked against the shaders at compile time).
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Self::with_variant(gpu, tiled(gpu))
    }

    /// The pass with a chosen splat: tiled (GPUs) or one thread per sprite (CPU drivers) — the same sums either
    /// way (the tests run both on any device).
    pub fn with_variant(gpu: &Arc<Gpu>, tiled: bool) -> Result<Self> {
        let splat = if tiled {
            Splat::Tiled(Box::new(TiledSplat {
                bin: ComputeProgram::new(gpu, &BIN)?,
                fill: ComputeProgram::new(gpu, &FILL)?,
                scan: ComputeProgram::new(gpu, &SCAN)?,
                gather: ComputeProgram::new(gpu, &GATHER)?,
            }))
        } else {
            Splat::Alone(Box::new(SpriteSplat {
                cull: ComputeProgram::new(gpu, &CULL)?,
                splat: ComputeProgram::new(gpu, &SPLAT)?,
                args: ComputeProgram::new(gpu, &ARGS)?,
            }))
        };
        Ok(Noise { splat, small: SMALL_SPRITE, clear: Clear::new(gpu)?, resolve: ComputeProgram::new(gpu, &RESOLVE)? })
    }

    /// Whether this pass splats through tiles (its targets' [`NoiseTargets::reserve`] takes it).
    pub fn is_tiled(&self) -> bool {
        matches!(self.splat, Splat::Tiled(_))
    }

    /// Splat the `count` particles' noise and resolve it into N (the atlas's level 0). The splat needs its lists
    /// reserved for `count` particles (else the frame gets no noise: the renderer reserves them before recording).
    pub fn record(&self, ctx: &mut FrameCtx, frame: &Buffer, particles: (&Buffer, u32), i: &NoiseImages, p: &Params) {
        let own = i.own;
        ctx.pass(NAME, |ctx| {
            ctx.part("noise/clear", |ctx| {
                ctx.fill(&own.work, 0);
                self.clear.record(ctx, &own.accum, 0);
            });
            let (buf, count) = particles;
            let (width, height) = own.size();
            let tiles = tile_count(width, height);
            let g = groups_2d(width, height, super::LOCAL_2D);
            let push = SpritePush {
                count,
                size: p.size,
                freq: p.frequency,
                falloff: p.falloff,
                calm: p.calm,
                turbulent: p.turbulent,
                threshold: p.threshold,
                tiles,
                small: self.small,
                lod: p.lod_samples,
                resolve: [g[0], g[1]],
            };
            let groups = [count.div_ceil(super::LOCAL_1D), 1, 1];
            let bins = own.bins.as_ref().filter(|b| b.particles >= count);
            let listed = own.listed.as_ref().filter(|_| own.listed_capacity() >= count);
            match (&self.splat, bins) {
                (Splat::Tiled(t), Some(b)) => {
                    let TiledSplat { bin, fill, scan, gather } = &**t;
                    ctx.fill(&b.tiles, 0);
                    let res = [
                        frame.into(),
                        buf.into(),
                        i.depth.into(),
                        (&b.tiles).into(),
                        (&b.sprites).into(),
                        (&own.work).into(),
                        (&own.accum).into(),
                        (&b.binned).into(),
                    ];
                    ctx.part("noise/bin", |ctx| bin.dispatch(ctx, &res, &push, groups));
                    let res = [(&b.tiles).into(), (&own.work).into(), (&b.args).into()];
                    ctx.part("noise/scan", |ctx| scan.dispatch(ctx, &res, &push, [1, 1, 1]));
                    let res = [
                        (&b.sprites).into(),
                        (&b.binned).into(),
                        (&own.work).into(),
                        i.depth.into(),
                        (&b.tiles).into(),
                        (&b.lists).into(),
                    ];
                    ctx.part("noise/fill", |ctx| fill.dispatch_indirect(ctx, &res, &push, &b.args, 0));
                    let res = [
                        frame.into(),
                        (&b.sprites).into(),
                        (&b.tiles).into(),
                        (&b.lists).into(),
                        i.depth.into(),
                        (&own.accum).into(),
                        (&own.work).into(),
                    ];
                    ctx.part("noise/gather", |ctx| gather.dispatch_indirect(ctx, &res, &push, &b.args, 12));
                }
                (Splat::Alone(a), _) => {
                    let SpriteSplat { cull, splat, args } = &**a;
                    if let Some(list) = listed {
                        let res = [frame.into(), buf.into(), i.depth.into(), (&own.work).into(), list.into()];
                        ctx.part("noise/cull", |ctx| cull.dispatch(ctx, &res, &push, groups));
                        let res = [(&own.work).into(), (&own.sprite_args).into()];
                        ctx.part("noise/args", |ctx| args.dispatch(ctx, &res, &push, [1, 1, 1]));
                        let res = [
                            frame.into(),
                            buf.into(),
                            i.depth.into(),
                            (&own.accum).into(),
                            (&own.work).into(),
                            list.into(),
                        ];
                        let a = &own.sprite_args;
                        ctx.part("noise/splat", |ctx| splat.dispatch_indirect(ctx, &res, &push, a, 16));
                    }
                }
                // Bins too small for these particles: no noise this frame rather than lost writes.
                (Splat::Tiled(_), None) => {}
            }
            let res = [frame.into(), (&own.accum).into(), i.depth.into(), (&own.work).into()];
            // As the splat counted it (noise_args, or noise_scan at its args[8..11]): no work groups at level 0
            // alone. No splat this frame (bins too small): the sums are 0, at level 0.
            let counted = match (&self.splat, bins) {
                (Splat::Alone(_), _) => listed.map(|_| (&own.sprite_args, 0)),
                (Splat::Tiled(_), Some(b)) => Some((&b.args, 32)),
                (Splat::Tiled(_), None) => None,
            };
            if let Some((args, offset)) = counted {
                ctx.part("noise/resolve", |ctx| self.resolve.dispatch_indirect(ctx, &res, &(), args, offset));
            }
        });
    }
}

pub mod reference;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::section::Section;

    /// The noise is 0 on the integer lattice and bounded; the amplitude ramps from calm to turbulent around the
    /// threshold; the defaults pass their own check and bad values name their key.
    #[test]
    fn kernel_and_settings() {
        assert_eq!(reference::perlin([3.0, -2.0], 12345), 0.0);
        let (mut max, mut sq) = (0f32, 0f64);
        let n = 200_000;
        for k in 0..n {
            let t = k as f32 * 0.0137;
            let v = reference::perlin([t, t * 0.7 + 3.1], k as u32 / 97);
            max = max.max(v.abs());
            sq += (v as f64).powi(2);
        }
        // Bounded by 1, and NOISE_2D_RMS brings its RMS to the 3D gradient noise's 0.270 (±3 %).
        let rms = reference::RMS_2D as f64 * (sq / n as f64).sqrt();
        assert!(max > 0.5 && max <= 1.0, "{max}");
        assert!((rms - 0.270).abs() < 0.03 * 0.270, "RMS {rms}");
        let p = Params::default();
        assert_eq!(reference::amplitude(0.0, &p), p.calm);
        assert_eq!(reference::amplitude(2.0 * p.threshold, &p), p.turbulent);
        assert!(reference::amplitude(p.threshold, &p) > p.calm && reference::amplitude(p.threshold, &p) < p.turbulent);
        assert!(p.check().is_ok());
        assert_eq!(Params { size: 0.0, ..p.clone() }.check().unwrap_err().0, "size");
        assert_eq!(Params { whitecaps_full: 0.1, ..p.clone() }.check().unwrap_err().0, "whitecaps_full");
        assert_eq!(Params { lod_samples: 1.5, ..p.clone() }.check().unwrap_err().0, "lod_samples");
        assert_eq!(Params { lod_samples: 8.0, ..p.clone() }.check().unwrap_err().0, "lod_samples");
        assert!(Params { lod_samples: 3.0, ..p.clone() }.check().is_ok());
    }
}
