//! `splat` pass: nearest linear eye depth of every particle sphere. Default: the compute splat with
//! atomicMin (shaders_glsl/splat.comp; the depth image is R32_SFLOAT with an R32_UINT view for the atomics).
//! Rasterised variants for measurement (`SplatMode`): quads or point sprites with gl_FragDepth, conservative
//! depth, or MIN blending (shaders_glsl/splat_{quad,point}.vert + splat_{fragdepth,conservative,min}.frag).
use std::sync::Arc;

use ash::vk;

use crate::error::{Error, Result};
use crate::gpu::pipeline::{bt::*, GraphicsProgram, RasterTargets};
use crate::gpu::{Access, Bind, Buffer, ComputeProgram, FrameCtx, Gpu, Image, Use};
use crate::settings::SplatMode;
use crate::shaders;

pub const NAME: &str = "splat";

/// Per-thread pixel budget: a sphere covering more (it swallowed the camera) is skipped.
pub const MAX_PIXELS_PER_PARTICLE: u32 = 1 << 20;

/// Tile size of the occlusion bound (`splat_cull`).
pub const TILE: u32 = 8;

pub struct Splat {
    prog: ComputeProgram,
    cull: ComputeProgram,
    /// Rasterised variants, by mode; None where the device lacks what the variant needs.
    raster: Vec<(SplatMode, Option<GraphicsProgram>)>,
}

/// Push constants of the rasterised variants (splat_raster.glsl).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct RasterPush {
    count: u32,
    radius_scale: f32,
    size: [f32; 2],
}

impl Splat {
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        let props = unsafe { gpu.instance.get_physical_device_format_properties(gpu.physical, vk::Format::R32_SFLOAT) };
        let can_blend = props.optimal_tiling_features.contains(vk::FormatFeatureFlags::COLOR_ATTACHMENT_BLEND);
        let mut raster = vec![];
        for mode in SplatMode::ALL.iter().copied().filter(|m| *m != SplatMode::Compute) {
            let point = matches!(mode, SplatMode::PointFragDepth | SplatMode::PointMin);
            let min = matches!(mode, SplatMode::QuadMin | SplatMode::PointMin);
            let frag = match mode {
                SplatMode::QuadConservative => shaders::SPLAT_CONSERVATIVE_FRAG,
                _ if min => shaders::SPLAT_MIN_FRAG,
                _ => shaders::SPLAT_FRAGDEPTH_FRAG,
            };
            let vert = if point { shaders::SPLAT_POINT_VERT } else { shaders::SPLAT_QUAD_VERT };
            let t = RasterTargets {
                color_format: vk::Format::R32_SFLOAT,
                depth_format: (!min).then_some(vk::Format::D32_SFLOAT),
                min_blend: min,
                topology: if point { vk::PrimitiveTopology::POINT_LIST } else { vk::PrimitiveTopology::TRIANGLE_LIST },
            };
            let prog = if min && !can_blend {
                None
            } else {
                Some(GraphicsProgram::new(gpu, NAME, vert, frag, &[UBO, SSBO], 16, t)?)
            };
            raster.push((mode, prog));
        }
        Ok(Splat {
            prog: ComputeProgram::new(gpu, NAME, shaders::SPLAT, &[UBO, SSBO, IMG, IMG, IMG], 24)?,
            cull: ComputeProgram::new(gpu, NAME, shaders::SPLAT_CULL, &[UBO, SSBO, IMG], 24)?,
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
        zbuffer: &Image,
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
        let point = matches!(mode, SplatMode::PointFragDepth | SplatMode::PointMin);
        let mut uses = vec![
            Use::Buffer(frame, Access::GraphicsRead),
            Use::Buffer(particles, Access::GraphicsRead),
            Use::Image(depth, Access::ColorAttachment, true),
        ];
        if !min {
            uses.push(Use::Image(zbuffer, Access::DepthAttachment, true));
        }
        ctx.pass(NAME, &uses, |ctx| {
            let push =
                RasterPush { count, radius_scale, size: [depth.extent.width as f32, depth.extent.height as f32] };
            let vertices = if point { count } else { count * 6 };
            let z = (!min).then_some(zbuffer);
            prog.draw(
                ctx,
                &[Bind::Uniform(frame), Bind::StorageBuf(particles)],
                bytemuck::bytes_of(&push),
                depth,
                f32::INFINITY,
                z,
                vertices,
            );
        });
        Ok(())
    }

    /// Clears `depth` to +inf ("no fluid") and splats `count` particles into it; with `back`, also the
    /// farthest sphere exit per pixel into `back_img` (cleared to 0). With `cull` (and without `back`, which
    /// needs every sphere), `splat_cull` first bounds each 8×8 tile's depth (`tiles`) so hidden spheres skip
    /// the tile; worth it when spheres span tiles (see `cull_pays`). `radius_scale`: spheres of this
    /// many particle radii.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        particles: &Buffer,
        count: u32,
        depth: &Image,
        back_img: &Image,
        tiles: &Image,
        back: bool,
        cull: bool,
        radius_scale: f32,
    ) {
        let uses = [
            Use::Image(depth, Access::TransferDst, true),
            Use::Image(back_img, Access::TransferDst, true),
            Use::Image(tiles, Access::TransferDst, true),
        ];
        ctx.pass(NAME, &uses, |ctx| {
            clear(ctx, depth, vk::ClearColorValue { float32: [f32::INFINITY; 4] });
            clear(ctx, back_img, vk::ClearColorValue { float32: [0.0; 4] });
            clear(ctx, tiles, vk::ClearColorValue { uint32: [f32::INFINITY.to_bits(); 4] });
            let groups = [count.div_ceil(super::LOCAL_1D), 1, 1];
            let cull = cull && !back;
            if cull {
                ctx.barrier(&[Use::buf_read(frame), Use::buf_read(particles), Use::write(tiles)]);
                let push = [count, radius_scale.to_bits(), TILE, 0, depth.extent.width, depth.extent.height];
                let binds = [Bind::Uniform(frame), Bind::StorageBuf(particles), Bind::Storage(tiles)];
                self.cull.dispatch(ctx, &binds, bytemuck::cast_slice(&push), groups);
            }
            ctx.barrier(&[
                Use::buf_read(frame),
                Use::buf_read(particles),
                Use::write(depth),
                Use::write(back_img),
                Use::read(tiles),
            ]);
            let push = [count, MAX_PIXELS_PER_PARTICLE, radius_scale.to_bits(), back as u32, cull as u32, TILE];
            self.prog.dispatch(
                ctx,
                &[
                    Bind::Uniform(frame),
                    Bind::StorageBuf(particles),
                    Bind::StorageAlt(depth),
                    Bind::StorageAlt(back_img),
                    Bind::Storage(tiles),
                ],
                bytemuck::cast_slice(&push),
                groups,
            );
        });
    }
}

/// Whether the occlusion pre-pass pays: spheres of `radius_px` pixels (at the camera's target distance) reach
/// half a tile. Measured on lavapipe, moritz preset, splat ms without → with the pre-pass: worst case (block
/// filling the screen) 912 → 183 at 1920×1080 and 235 → 76 at 960×540; wave and crown 1 unchanged (their
/// spheres stay below the threshold or barely hide each other).
pub fn cull_pays(radius_px: f32) -> bool {
    radius_px >= TILE as f32 * 0.5
}

/// Clear a whole image that is in TRANSFER_DST layout (the caller declared `Access::TransferDst`).
pub(crate) fn clear(ctx: &FrameCtx, img: &Image, value: vk::ClearColorValue) {
    unsafe {
        ctx.gpu.device.cmd_clear_color_image(
            ctx.cmd,
            img.raw,
            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
            &value,
            &[Image::color_range()],
        )
    };
}
