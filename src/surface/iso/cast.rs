//! The `iso` pass: the depth of the SPH colour-field iso-surface, ray-cast per pixel from the splatted bound
//! spheres' depth (which it replaces) to their far bound — two dispatches: the first samples of every ray over
//! the tiles that hold fluid, then the queued long rays (`queue`) — over the exact field, the anisotropic
//! kernels' or the smoothed field's lattice (`volume`), with coarse-to-fine where particles are large on
//! screen. Shaders: shaders_glsl/iso/iso.comp and its variants (iso_vol, iso_aniso, iso_rest, iso_blocks,
//! iso_fine, iso_tiles), the field in iso_field.glsl, the march in iso_cast.glsl. CPU reference:
//! `IsoGrid::ray_cast` in src/field/iso/mod.rs.
//! In: the grid's weighted points and empty-distance cell table, the depth, the far bound. Out: the depth.
use std::sync::Arc;

use crate::declare_program;
use crate::error::Result;
use crate::gpu::{groups_2d, Buffer, ComputeProgram, FrameCtx, Gpu, Image};
use crate::passes::{FrameInfo, LOCAL_2D};
use crate::shaders;
use crate::surface::grid::{IsoBuffers, IsoPush};

use super::params::{FINE_SPREAD, FINE_STEP};
use super::queue::{self, IsoQueue};
use super::volume::IsoVolume;

/// The pass's one name (shader stem, debug label, timestamp key, JSON key): `iso`.
pub const NAME: &str = "iso";

/// The pass's compute programs, built once per device (by the iso surface, on its first frame).
pub struct IsoCast {
    cast: ComputeProgram<IsoPush>,
    cast_blocks: ComputeProgram<IsoPush>,
    cast_aniso: ComputeProgram<IsoPush>,
    /// The tiles that hold fluid, for the first dispatch (iso_tiles.comp).
    tiles: ComputeProgram<()>,
    rest: ComputeProgram<IsoPush>,
    rest_aniso: ComputeProgram<IsoPush>,
    fine: ComputeProgram<IsoPush>,
    cast_vol: ComputeProgram<IsoPush>,
    rest_vol: ComputeProgram<IsoPush>,
    /// The queued rays marched by 8 and by 32 lanes each (exact and smoothed field), where the device shuffles
    /// within subgroups that wide (`DeviceInfo::subgroup_shuffle`, `subgroup_size`).
    rest_wide8: Option<[ComputeProgram<IsoPush>; 2]>,
    /// With 32 lanes: [32 lanes for few rays, 8 for many] per field (exact, smoothed).
    rest_wide32: Option<[[ComputeProgram<IsoPush>; 2]; 2]>,
}

// Ray cast: frame, the weighted points, the cell table, depth (read as the start, written as the surface), back
// depth, the queue of unfinished rays and its header (written).
declare_program!(pub CAST: IsoPush = compute(shaders::ISO, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufWrite, BufWrite, BufWrite, BufRead]));
// The tiles of the bound spheres' depth that hold fluid: frame (binding 0, unread), depth → the queue's header (the first dispatch's work
// groups), the tiles listed; the first dispatch (CAST, CAST_ANISO, CAST_VOL) reads them after its work counts.
declare_program!(pub TILES: () = compute(shaders::ISO_TILES, [Uniform, ImgRead, BufWrite, BufWrite]));
// The first dispatch with coarse-to-fine on: one invocation per 2×2 block (iso_cast.glsl).
declare_program!(pub CAST_BLOCKS: IsoPush = compute(shaders::ISO_BLOCKS, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufWrite, BufWrite, BufWrite]));
// The same over the anisotropic kernels (a separate program: a run-time branch in the field's inner loop doubled
// the isotropic cast's cost on lavapipe, 553 → 988 ms on the dam-break frame at 960×540).
declare_program!(pub CAST_ANISO: IsoPush = compute(shaders::ISO_ANISO, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufWrite, BufWrite, TexelRead, BufWrite, BufRead]));
// The second dispatches: the queued rays finished (the queue and its header read).
declare_program!(pub REST: IsoPush = compute(shaders::ISO_REST, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufRead, BufRead, BufWrite]));
// The same, 8 or 32 lanes per ray (`[iso] rest_lanes`; iso_cast.glsl).
declare_program!(pub REST_WIDE8: IsoPush = compute(shaders::ISO_REST_WIDE8, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufRead, BufRead, BufWrite]));
declare_program!(pub REST_WIDE32: IsoPush = compute(shaders::ISO_REST_WIDE32, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufRead, BufRead, BufWrite]));
declare_program!(pub REST_WIDE8_MANY: IsoPush = compute(shaders::ISO_REST_WIDE8_MANY, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufRead, BufRead, BufWrite]));
declare_program!(pub REST_ANISO: IsoPush = compute(shaders::ISO_ANISO_REST, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufRead, BufRead, TexelRead, BufWrite]));
// Coarse-to-fine (isotropic only), twice: phase 0 (fine.y = 0) polishes the marched pixels with a Newton step;
// phase 1 gives the pixels the first dispatches left their marched neighbours' depth (with a Newton step where
// the surface curves) and queues those it cannot trust (round 1) for a second `rest`.
declare_program!(pub FINE: IsoPush = compute(shaders::ISO_FINE, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufWrite, BufWrite, BufWrite]));

// The casts over the smoothed field: frame, weighted points, cells, depth, back, queue, header, table, field.
declare_program!(pub CAST_VOL: IsoPush = compute(shaders::ISO_VOL, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufWrite, BufWrite, TexelRead, TexelRead, BufWrite, BufRead]));
declare_program!(pub REST_VOL: IsoPush = compute(shaders::ISO_VOL_REST, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufRead, BufRead, TexelRead, TexelRead, BufWrite]));
declare_program!(pub REST_VOL_WIDE8: IsoPush = compute(shaders::ISO_VOL_REST_WIDE8, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufRead, BufRead, TexelRead, TexelRead, BufWrite]));
declare_program!(pub REST_VOL_WIDE32: IsoPush = compute(shaders::ISO_VOL_REST_WIDE32, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufRead, BufRead, TexelRead, TexelRead, BufWrite]));
declare_program!(pub REST_VOL_WIDE8_MANY: IsoPush = compute(shaders::ISO_VOL_REST_WIDE8_MANY, [Uniform, TexelRead, TexelRead, ImgWrite, ImgRead, BufRead, BufRead, TexelRead, TexelRead, BufWrite]));

impl IsoCast {
    /// Build the pass's pipelines (their slot lists were checked against the shaders at compile time).
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(IsoCast {
            cast: ComputeProgram::new(gpu, &CAST)?,
            cast_blocks: ComputeProgram::new(gpu, &CAST_BLOCKS)?,
            cast_aniso: ComputeProgram::new(gpu, &CAST_ANISO)?,
            tiles: ComputeProgram::new(gpu, &TILES)?,
            rest: ComputeProgram::new(gpu, &REST)?,
            rest_aniso: ComputeProgram::new(gpu, &REST_ANISO)?,
            fine: ComputeProgram::new(gpu, &FINE)?,
            cast_vol: ComputeProgram::new(gpu, &CAST_VOL)?,
            rest_vol: ComputeProgram::new(gpu, &REST_VOL)?,
            rest_wide8: if gpu.info.shuffle_lanes(8) == 8 {
                Some([ComputeProgram::new(gpu, &REST_WIDE8)?, ComputeProgram::new(gpu, &REST_VOL_WIDE8)?])
            } else {
                None
            },
            rest_wide32: if gpu.info.shuffle_lanes(32) == 32 {
                Some([
                    [ComputeProgram::new(gpu, &REST_WIDE32)?, ComputeProgram::new(gpu, &REST_WIDE8_MANY)?],
                    [ComputeProgram::new(gpu, &REST_VOL_WIDE32)?, ComputeProgram::new(gpu, &REST_VOL_WIDE8_MANY)?],
                ])
            } else {
                None
            },
        })
    }

    /// Ray-cast the iso-surface into `depth` (which holds the bound spheres' depth on entry); `back`: the far
    /// bound from the splat, per pixel or per 8×8 tile, where the march may stop (else it runs to the grid's box);
    /// `queue`: where the first dispatch leaves the rays the second finishes. Coarse-to-fine runs when the
    /// nearest particle (`info.d_near`) is at least `[iso] fine_px` pixels in radius on screen.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        b: &IsoBuffers,
        params: &crate::field::iso::IsoParams,
        depth: &Image,
        volume: Option<&IsoVolume>,
        back: Option<crate::passes::splat::BackBound>,
        queue: &IsoQueue,
        info: &FrameInfo,
    ) {
        use crate::passes::splat::BackBound;
        let (mode, back) = match back {
            None => (0, None),
            Some(BackBound::Pixel(i)) => (1, Some(i)),
            Some(BackBound::Tile(i)) => (2, Some(i)),
        };
        let mut push = cast_push(b.shape, params, mode);
        if params.radius * info.focal_px_fluid < params.fine_px * info.d_near {
            push.fine[0] = 0.0;
        }
        // The smoothed field: its lattice in the push constants; no coarse-to-fine (no field gradient there).
        let volume = volume.zip(params.volume.as_ref());
        if let Some((v, vp)) = volume {
            push = v.push(push, vp);
            push.fine[0] = 0.0;
        }
        // Without a back image the binding still needs an image: the depth itself (never read then).
        let back_img = back.unwrap_or(depth);
        ctx.pass(NAME, |ctx| {
            ctx.fill(&queue.header, 0);
            ctx.fill(&queue.work.buffer, 0);
            // Coarse-to-fine: one invocation per 2×2 block (iso_cast.glsl).
            let block = if push.fine[0] > 0.0 { 2 } else { 1 };
            let (w, h) = (depth.extent.width.div_ceil(block), depth.extent.height.div_ceil(block));
            let g = groups_2d(w, h, LOCAL_2D);
            let (q, h) = ((&queue.entries).into(), (&queue.header).into());
            let mut all =
                vec![frame.into(), (&b.weighted).into(), (&b.cells_empty).into(), depth.into(), back_img.into(), q, h];
            let (cast, rest) = match (params.aniso, volume) {
                (Some(_), _) => {
                    all.push((&b.aniso).into());
                    (&self.cast_aniso, &self.rest_aniso)
                }
                (None, Some((v, _))) => {
                    all.push((&v.table).into());
                    all.push((&v.acc).into());
                    (&self.cast_vol, &self.rest_vol)
                }
                (None, None) => (&self.cast, &self.rest),
            };
            // The work counts after the field's bindings (iso_cast.glsl's ISO_WORK_BINDING).
            all.push((&queue.work.buffer).into());
            // Round 0's queued rays by 8 or 32 lanes each where asked for and the device can (isotropic only).
            let lanes = if params.aniso.is_none() { ctx.gpu.info.shuffle_lanes(params.rest_lanes) } else { 1 };
            let field = usize::from(volume.is_some());
            // (program, its arguments' offset) per dispatch: 32 lanes for few rays and 8 for many both run, one
            // of them finding nothing to do.
            let wide: Vec<(&ComputeProgram<IsoPush>, u64)> = match (lanes, &self.rest_wide8, &self.rest_wide32) {
                (32, _, Some(w)) => vec![(&w[field][0], queue::WIDE32_ARGS), (&w[field][1], queue::WIDE8_ARGS)],
                (8, Some(w), _) => vec![(&w[field], queue::WIDE8_ARGS)],
                _ => vec![],
            };
            let fine = push.fine[0] > 0.0;
            if fine {
                ctx.part("iso/cast", |ctx| self.cast_blocks.dispatch(ctx, &all, &push, g));
            } else {
                // A work group per tile of the bound spheres' depth that holds fluid (iso_tiles.comp).
                ctx.part("iso/tiles", |ctx| {
                    self.tiles.dispatch(ctx, &[frame.into(), depth.into(), h, (&queue.tiles).into()], &(), g);
                });
                let mut first = all.clone();
                first.push((&queue.tiles).into());
                ctx.part("iso/cast", |ctx| {
                    cast.dispatch_indirect(ctx, &first, &push, &queue.header, queue::TILES_ARGS)
                });
            }
            if push.steps[3] < push.steps[0] {
                ctx.part("iso/rest", |ctx| {
                    if wide.is_empty() {
                        rest.dispatch_indirect(ctx, &all, &push, &queue.header, 0);
                    }
                    for (w, at) in &wide {
                        w.dispatch_indirect(ctx, &all, &push, &queue.header, *at);
                    }
                });
            }
            if fine {
                let phase = |k: f32| IsoPush { fine: [push.fine[0], k, push.fine[2], push.fine[3]], ..push };
                ctx.part("iso/fine", |ctx| {
                    self.fine.dispatch(ctx, &all, &phase(0.0), g);
                    self.fine.dispatch(ctx, &all, &phase(1.0), g);
                });
                ctx.part("iso/fine_rest", |ctx| rest.dispatch_indirect(ctx, &all, &phase(1.0), &queue.header, 16));
            }
        });
    }
}

/// The grid's shape `shape` with the march parameters `p`; `back`: 0, or the far bound per pixel (1) or per 8×8
/// tile (2).
fn cast_push(shape: IsoPush, p: &crate::field::iso::IsoParams, back: u32) -> IsoPush {
    IsoPush {
        params: [shape.params[0], p.threshold, p.step, p.bound],
        steps: [p.max_steps, p.refine, back, if p.first_steps == 0 { p.max_steps } else { p.first_steps }],
        aniso2: [p.aniso.map_or(1.0, |a| a.stretch.max(1.0)), 0.0, 0.0, 0.0],
        // No gradient of the anisotropic field: those casts march every pixel. `record` turns it off for a
        // frame whose particles are all smaller on screen.
        fine: [
            if p.aniso.is_none() && p.fine_px > 0.0 { p.radius / p.fine_px } else { 0.0 },
            0.0,
            FINE_SPREAD * p.radius,
            FINE_STEP * p.radius,
        ],
        ..shape
    }
}
