//! `splat` pass: nearest linear eye depth of every particle sphere. Default: the compute splat with
//! atomicMin (shaders_glsl/splat.comp; the depth image is R32_SFLOAT with an R32_UINT view for the atomics).
//! Rasterised variants for measurement (`SplatMode`): quads or point sprites with gl_FragDepth, conservative
//! depth, or MIN blending (shaders_glsl/splat_{quad,point}.vert + splat.frag, compiled once per variant).
use std::sync::Arc;

use ash::vk;

use crate::compute::clear::Clear;
use crate::declare_program;
use crate::error::{Error, Result};
use crate::passes::FrameInfo;
use crate::named::SplatMode;
use crate::gpu::{GraphicsProgram, ProgramDecl, RasterTargets};
use crate::gpu::{Buffer, ComputeProgram, FrameCtx, Gpu, Image};
use crate::shaders;

/// The pass's one name (module, shader stem, debug label, timestamp key, JSON key): `splat`.
pub const NAME: &str = "splat";

/// Settings of the `splat` pass: the `[splat]` section of a settings file.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// How the depth splat draws.
    pub mode: SplatMode,
    /// The depth splat draws spheres of this many particle radii (1 = the particles themselves).
    pub radius_scale: f32,
    /// Lanes that draw one large sphere together (1, 2, 4, 8, 16 or 32; 0 = by the device): where spheres span
    /// tiles (the occlusion pre-pass runs), each sphere's pixels are split over this many consecutive
    /// invocations instead of walked by one. By the device: 32 where subgroups hold 32 lanes or more (GPUs,
    /// where one thread walking ~90 pixels kept its warp waiting: the worst case's splat 3.4 ms on an H200), 1
    /// on lavapipe (subgroups of 8 CPU SIMD lanes, which run a loop's masked lanes anyway). The depth is the
    /// same either way (atomicMin does not care who writes); only the time changes.
    pub lanes: u32,
}

impl Default for Params {
    fn default() -> Self {
        Params { mode: SplatMode::Compute, radius_scale: 1.3, lanes: 0 }
    }
}

impl crate::section::Section for Params {
    fn name(&self) -> &'static str {
        NAME
    }

    fn check(&self) -> crate::section::Checked {
        let k = crate::section::Keys(NAME);
        k.within("radius_scale", self.radius_scale, 0.25, 4.0)?;
        if !(self.lanes == 0 || (self.lanes.is_power_of_two() && self.lanes <= 32)) {
            return Err(("lanes", format!("[splat] lanes = {}: 0 (by the device), 1, 2, 4, 8, 16 or 32", self.lanes)));
        }
        Ok(())
    }
}

use crate::shader_constants::SPLAT_TILE as TILE;

/// The pass: its compute program(s), built once per device.
pub struct Splat {
    /// `[splat] lanes` = 0 on this device ([`Params::lanes`]).
    device_lanes: u32,
    prog: ComputeProgram<SplatPush>,
    cull: ComputeProgram<CullPush>,
    /// The depth, tile and far-bound images' clears.
    clear: Clear,
    /// Rasterised variants, by mode; None where the device lacks what the variant needs.
    raster: Vec<(SplatMode, Option<GraphicsProgram<RasterPush>>)>,
}

/// Push constants of splat.comp.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SplatPush {
    /// Particles.
    pub count: u32,
    /// Sphere radius in particle radii.
    pub radius_scale: f32,
    /// 1: skip spheres hidden in a whole tile.
    pub cull: u32,
    /// Tile size of the occlusion bound.
    pub tile: u32,
    /// 1: the particles are the iso grid's points, drawn as their anisotropic kernels' ellipsoids.
    pub ellipsoid: u32,
    /// The kernels' longest axis relative to ∛det M (`[anisotropy] stretch`, at least 1).
    pub stretch: f32,
    /// 1: also write the farthest exit per pixel (never with `cull`).
    pub back: u32,
    /// Consecutive invocations per sphere (1: one thread walks the sphere's pixels).
    pub lanes: u32,
    /// Invocations per row of the dispatch's grid (work groups × LOCAL_1D along x): the linear index spans rows.
    pub row: u32,
}

/// Where the `iso` march's far bound was written: per pixel by the splat, or per 8×8 tile by its pre-pass (when
/// the splat culls, the per-pixel bound would need every sphere).
#[derive(Clone, Copy)]
pub enum BackBound<'a> {
    /// The farthest sphere exit of each pixel.
    Pixel(&'a Image),
    /// The deepest centre depth + radius of the spheres touching each tile.
    Tile(&'a Image),
}

/// Push constants of splat_cull.comp.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CullPush {
    /// Particles.
    pub count: u32,
    /// Sphere radius in particle radii.
    pub radius_scale: f32,
    /// Tile size.
    pub tile: u32,
    /// 1: also write the far bound per tile (the `iso` march's).
    pub back: u32,
    /// Depth image size in pixels.
    pub size: [u32; 2],
}

/// Push constants of the rasterised variants (splat_raster.glsl).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RasterPush {
    /// Particles.
    pub count: u32,
    /// Sphere radius in particle radii.
    pub radius_scale: f32,
    /// Fluid image size in pixels.
    pub size: [f32; 2],
}

// The compute splat: frame, particles, depth (R32_UINT view, atomicMin), the tile bounds, the anisotropic
// kernels (read with `ellipsoid`), the per-pixel far bound (R32_UINT view, atomicMax, with `back`).
declare_program!(pub SPLAT: SplatPush = compute(shaders::SPLAT, [Uniform, BufRead, ImgAltWrite, ImgRead, BufRead, ImgAltWrite, BufWrite]));
// The pre-pass: frame, particles → per-tile occlusion bound (atomicMin) and far bound (R32_UINT view, atomicMax).
declare_program!(pub CULL: CullPush = compute(shaders::SPLAT_CULL, [Uniform, BufRead, ImgWrite, ImgAltWrite]));
// The rasterised variants: frame and particles, read by the vertex and fragment shaders.
declare_program!(pub QUAD_FRAG_DEPTH: RasterPush = graphics(shaders::SPLAT_QUAD_VERT, shaders::SPLAT_FRAGDEPTH_FRAG, [Uniform, BufRead]));
declare_program!(pub QUAD_CONSERVATIVE: RasterPush = graphics(shaders::SPLAT_QUAD_VERT, shaders::SPLAT_CONSERVATIVE_FRAG, [Uniform, BufRead]));
declare_program!(pub QUAD_MIN: RasterPush = graphics(shaders::SPLAT_QUAD_VERT, shaders::SPLAT_MIN_FRAG, [Uniform, BufRead]));
declare_program!(pub POINT_FRAG_DEPTH: RasterPush = graphics(shaders::SPLAT_POINT_VERT, shaders::SPLAT_FRAGDEPTH_FRAG, [Uniform, BufRead]));
declare_program!(pub POINT_MIN: RasterPush = graphics(shaders::SPLAT_POINT_VERT, shaders::SPLAT_MIN_FRAG, [Uniform, BufRead]));

/// The program of a rasterised mode (None for the compute splat).
pub fn raster_program(mode: SplatMode) -> Option<&'static ProgramDecl<RasterPush>> {
    match mode {
        SplatMode::Compute => None,
        SplatMode::QuadFragDepth => Some(&QUAD_FRAG_DEPTH),
        SplatMode::QuadConservative => Some(&QUAD_CONSERVATIVE),
        SplatMode::QuadMin => Some(&QUAD_MIN),
        SplatMode::PointFragDepth => Some(&POINT_FRAG_DEPTH),
        SplatMode::PointMin => Some(&POINT_MIN),
    }
}

impl Splat {
    /// Build the pass's pipelines (their slot lists were checked against the shaders at compile time).
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        let props = unsafe { gpu.instance.get_physical_device_format_properties(gpu.physical, vk::Format::R32_SFLOAT) };
        let can_blend = props.optimal_tiling_features.contains(vk::FormatFeatureFlags::COLOR_ATTACHMENT_BLEND);
        let mut raster = vec![];
        for mode in SplatMode::ALL.iter().copied().filter(|m| *m != SplatMode::Compute) {
            let point = matches!(mode, SplatMode::PointFragDepth | SplatMode::PointMin);
            let min = matches!(mode, SplatMode::QuadMin | SplatMode::PointMin);
            let t = RasterTargets {
                color_format: vk::Format::R32_SFLOAT,
                depth_format: (!min).then_some(vk::Format::D32_SFLOAT),
                min_blend: min,
                topology: if point { vk::PrimitiveTopology::POINT_LIST } else { vk::PrimitiveTopology::TRIANGLE_LIST },
            };
            let prog = match raster_program(mode) {
                Some(decl) if can_blend || !min => Some(GraphicsProgram::new(gpu, decl, t)?),
                _ => None,
            };
            raster.push((mode, prog));
        }
        Ok(Splat {
            device_lanes: if gpu.info.subgroup_size >= 32 { 32 } else { 1 },
            prog: ComputeProgram::new(gpu, &SPLAT)?,
            cull: ComputeProgram::new(gpu, &CULL)?,
            clear: Clear::new(gpu)?,
            raster,
        })
    }

    /// Whether `mode` can run on this device.
    pub fn supports(&self, mode: SplatMode) -> bool {
        mode == SplatMode::Compute || self.raster.iter().any(|(m, p)| *m == mode && p.is_some())
    }

    /// Rasterised splat into `depth` (as colour attachment) with `zbuffer` for the depth-tested variants.
    #[allow(clippy::too_many_arguments)]
    pub fn record_raster(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        particles: &Buffer,
        count: u32,
        depth: &Image,
        zbuffer: Option<&Image>,
        radius_scale: f32,
        mode: SplatMode,
    ) -> Result<()> {
        let prog = self
            .raster
            .iter()
            .find(|(m, _)| *m == mode)
            .and_then(|(_, p)| p.as_ref())
            .ok_or_else(|| Error::Invalid(format!("splat mode {mode:?} is not supported on this device")))?;
        let min = matches!(mode, SplatMode::QuadMin | SplatMode::PointMin);
        if !min && zbuffer.is_none() {
            return Err(Error::Invalid(format!("splat mode {} needs a depth buffer", mode.name())));
        }
        let point = matches!(mode, SplatMode::PointFragDepth | SplatMode::PointMin);
        ctx.pass(NAME, |ctx| {
            let push =
                RasterPush { count, radius_scale, size: [depth.extent.width as f32, depth.extent.height as f32] };
            let vertices = if point { count } else { count * 6 };
            let z = if min { None } else { zbuffer };
            prog.draw(ctx, &[frame.into(), particles.into()], &push, depth, f32::INFINITY, z, vertices);
        });
        Ok(())
    }

    /// Clears `depth` to +inf ("no fluid") and splats `count` particles into it, counting its work in `work`
    /// ([`crate::work::SplatWork`]). The pre-pass `splat_cull`
    /// bounds each 8×8 tile's depth (`tiles`) so hidden spheres skip the tile, when spheres span tiles
    /// ([`cull_pays`], from the sphere size in fluid pixels at the camera's target distance). With `back` (the
    /// per-pixel and the per-tile image, for the `iso` march) the far bound is written too, and returned: per
    /// pixel (the farthest sphere exit) when the splat does not cull, else per tile by the pre-pass (the deepest
    /// centre depth + radius of the spheres touching the tile). Spheres are `radius_scale` particle radii of
    /// `radius` (the frame's; particles may carry their own). With `ellipsoids` (the kernels `anisotropy` wrote
    /// for these particles, the iso grid's points, and their `stretch`) each sphere becomes its kernel's
    /// ellipsoid of the same volume (no cull, no far bound: both assume spheres).
    #[allow(clippy::too_many_arguments)]
    pub fn record<'a>(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        particles: &Buffer,
        count: u32,
        depth: &Image,
        back: Option<(&'a Image, &'a Image)>,
        (tiles, work): (&Image, &crate::work::Counters),
        (radius, radius_scale, lanes): (f32, f32, u32),
        ellipsoids: Option<(&Buffer, f32)>,
        info: &FrameInfo,
    ) -> Option<BackBound<'a>> {
        let cull = ellipsoids.is_none() && cull_pays(info.focal_px_fluid * radius * radius_scale / info.target_distance);
        // Lanes per sphere only where spheres are large (the cull runs); `[splat] lanes` 0 is the device's.
        let lanes = match (cull, lanes) {
            (false, _) => 1,
            (true, 0) => self.device_lanes,
            (true, l) => l,
        };
        let bound = back.filter(|_| ellipsoids.is_none()).map(|(pixel, tile)| {
            if cull {
                BackBound::Tile(tile)
            } else {
                BackBound::Pixel(pixel)
            }
        });
        let (kernels, stretch) = ellipsoids.unwrap_or((particles, 1.0));
        // Bindings without their image still need one: the depth itself (never written through it then).
        let pixel_back = match bound {
            Some(BackBound::Pixel(i)) => i,
            _ => depth,
        };
        let tile_back = match bound {
            Some(BackBound::Tile(i)) => i,
            _ => depth,
        };
        ctx.pass(NAME, |ctx| {
            ctx.part("splat/clear", |ctx| {
                self.clear.record(ctx, depth, f32::INFINITY.to_bits());
                self.clear.record(ctx, tiles, f32::INFINITY.to_bits());
                if let Some(BackBound::Pixel(i) | BackBound::Tile(i)) = bound {
                    self.clear.record(ctx, i, 0.0f32.to_bits());
                }
                ctx.fill(&work.buffer, 0);
            });
            let groups = [count.div_ceil(super::LOCAL_1D), 1, 1];
            if cull {
                let push = CullPush {
                    count,
                    radius_scale,
                    tile: TILE,
                    back: matches!(bound, Some(BackBound::Tile(_))) as u32,
                    size: [depth.extent.width, depth.extent.height],
                };
                let res = [frame.into(), particles.into(), tiles.into(), tile_back.into()];
                ctx.part("splat/cull", |ctx| self.cull.dispatch(ctx, &res, &push, groups));
            }
            // count × lanes invocations, in rows of at most 65,535 work groups (the dispatch's x limit).
            let total = (count as u64 * lanes as u64).div_ceil(super::LOCAL_1D as u64).max(1);
            let gx = total.min(65_535) as u32;
            let wide = [gx, total.div_ceil(gx as u64) as u32, 1];
            let push = SplatPush {
                count,
                radius_scale,
                cull: cull as u32,
                tile: TILE,
                ellipsoid: ellipsoids.is_some() as u32,
                stretch,
                back: matches!(bound, Some(BackBound::Pixel(_))) as u32,
                lanes,
                row: gx * super::LOCAL_1D,
            };
            let res =
                [frame.into(), particles.into(), depth.into(), tiles.into(), kernels.into(), pixel_back.into(), (&work.buffer).into()];
            ctx.part("splat/spheres", |ctx| self.prog.dispatch(ctx, &res, &push, wide));
        });
        bound
    }
}

/// Whether the occlusion pre-pass pays: spheres of `radius_px` pixels (at the camera's target distance) reach
/// half a tile. Measured on lavapipe, moritz preset, splat ms without → with the pre-pass: worst case (block
/// filling the screen) 912 → 183 at 1920×1080 and 235 → 76 at 960×540; wave and crown 1 unchanged (their
/// spheres stay below the threshold or barely hide each other).
pub fn cull_pays(radius_px: f32) -> bool {
    radius_px >= TILE as f32 * 0.5
}


