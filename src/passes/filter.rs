//! `filter` pass: depth smoothing, one of several filters chosen per run (`Filter`). Kernel widths are in
//! world units (multiples of the particle radius), converted per pixel from depth.
//! Shaders: shaders_glsl/filter_*.comp.
use std::sync::Arc;

use crate::declare_program;
use crate::error::Result;
use crate::passes::FrameInfo;
use crate::gpu::{groups_2d, Buffer, ComputeProgram, FrameCtx, Gpu, Image};
use crate::named::Filter;
use crate::shaders;

/// The pass's one name (module, shader stem, debug label, timestamp key, JSON key, settings section): `filter`.
pub const NAME: &str = "filter";

/// Settings of the `filter` pass: the `[filter]` section of a settings file (`[smooth]`: its deprecated
/// spelling).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Which filter (`--filter`; `filter`: the key's deprecated spelling).
    #[serde(alias = "filter")]
    pub method: Filter,
    /// World radius ρ of the smoothing kernel, in particle radii.
    pub radius: f32,
    /// Cap of the kernel radius in pixels.
    pub max_px: u32,
    /// `[filter.bilateral]`: Gaussian and bilateral filters.
    pub bilateral: BilateralParams,
    /// `[filter.narrow]`: the narrow-range filter.
    pub narrow: NarrowParams,
    /// `[filter.curvature]`: curvature flow.
    pub curvature: CurvatureParams,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            method: Filter::NarrowRange,
            radius: 4.0,
            max_px: 24,
            bilateral: BilateralParams::default(),
            narrow: NarrowParams::default(),
            curvature: CurvatureParams::default(),
        }
    }
}

impl crate::section::Section for Params {
    fn name(&self) -> &'static str {
        NAME
    }

    /// With its subsections `[filter.bilateral]`, `[filter.narrow]`, `[filter.curvature]` (dotted keys).
    fn check(&self) -> crate::section::Checked {
        let k = crate::section::Keys(NAME);
        k.above("radius", self.radius, 0.0, 1e3)?;
        k.count("max_px", self.max_px, 0, 64)?;
        let b = &self.bilateral;
        k.above("bilateral.sigma_range", b.sigma_range, 0.0, 1e4)?;
        k.count("bilateral.iterations", b.iterations, 0, 64)?;
        let n = &self.narrow;
        k.above("narrow.radius", n.radius, 0.0, 1e3)?;
        k.within("narrow.threshold", n.threshold, 0.0, 1e4)?;
        k.within("narrow.mu", n.mu, 0.0, 1e4)?;
        k.count("narrow.px_2d", n.px_2d, 0, 8)?;
        k.count("narrow.iterations", n.iterations, 0, 16)?;
        let c = &self.curvature;
        k.within("curvature.dt", c.dt, 0.0, 1e3)?;
        k.count("curvature.it_max", c.it_max, 0, 1000)?;
        k.within("curvature.radius", c.radius, 0.0, 1e3)?;
        k.within("curvature.kappa", c.kappa, 0.0, 1e3)?;
        k.count("curvature.iters_per_dispatch", c.iters_per_dispatch, 1, 4)?;
        k.within("curvature.edge", c.edge, 0.0, 1e4)
    }
}

/// Settings of the `filter` pass: the `[filter.bilateral]` section of a settings file.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BilateralParams {
    /// Range σ_r of the bilateral filter, in particle radii.
    pub sigma_range: f32,
    /// How many times the (separable) filter runs.
    pub iterations: u32,
}

impl Default for BilateralParams {
    fn default() -> Self {
        BilateralParams { sigma_range: 2.0, iterations: 2 }
    }
}

/// Settings of the `filter` pass: the `[filter.narrow]` section of a settings file.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NarrowParams {
    /// Narrow-range filter: world radius ρ of the kernel, in particle radii.
    pub radius: f32,
    /// Narrow-range filter: accepted range half-width, in particle radii (paper: 10–10.5).
    pub threshold: f32,
    /// Narrow-range filter: clamp offset μ behind the centre, in particle radii (paper: 1).
    pub mu: f32,
    /// Narrow-range filter: window radius of the final 2D pass, pixels.
    pub px_2d: u32,
    /// Narrow-range filter: how many times the separable + 2D passes run.
    pub iterations: u32,
    /// Narrow-range filter: background samples are skipped (true) or clamped to centre + μ like any far
    /// sample (false, the paper).
    pub skip_background: bool,
}

impl Default for NarrowParams {
    fn default() -> Self {
        NarrowParams { radius: 6.0, threshold: 10.0, mu: 1.0, px_2d: 2, iterations: 1, skip_background: true }
    }
}

/// Settings of the `filter` pass: the `[filter.curvature]` section of a settings file.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CurvatureParams {
    /// Curvature flow: time step Δt (Moritz: 0.005); 0 = the largest stable step at each pixel
    /// (λ = Δt·F/(2(d+κ)) = 0.2), which carries over between resolutions and scene scales.
    pub dt: f32,
    /// Curvature flow: iteration cap it_max (Moritz: 60).
    pub it_max: u32,
    /// Curvature flow: world radius ρ in particle radii; a pixel iterates F·ρ/d times (Moritz eq. 3.8).
    pub radius: f32,
    /// Curvature flow: κ stabiliser near the camera, world units (Moritz: 3).
    pub kappa: f32,
    /// Curvature flow: iterations per dispatch (2–4: shared-memory tile; 1: one untiled dispatch per iteration,
    /// the faster on lavapipe, see README's measurements).
    pub iters_per_dispatch: u32,
    /// Depth jump in particle radii that separates surfaces (curvature flow).
    pub edge: f32,
}

impl Default for CurvatureParams {
    fn default() -> Self {
        CurvatureParams { dt: 0.0, it_max: 60, radius: 12.0, kappa: 3.0, iters_per_dispatch: 1, edge: 6.0 }
    }
}

/// Which image holds the smoothed depth after the pass: its input (no filter), or the first or the second
/// ping-pong image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Output {
    /// The input itself (no filter).
    Input,
    /// The first ping-pong image.
    First,
    /// The second ping-pong image.
    Second,
}

/// The pass: its compute program(s), built once per device.
pub struct DepthFilter {
    bilateral: ComputeProgram<BilateralPush>,
    narrow: ComputeProgram<NarrowPush>,
    curvature: ComputeProgram<CurvaturePush>,
    curvature1: ComputeProgram<CurvaturePush>,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
/// Push constants of filter_narrow.comp.
pub struct NarrowPush {
    dir: [i32; 2],
    world_radius: f32,
    threshold: f32,
    mu: f32,
    max_px: i32,
    radius_2d: i32,
    skip_background: i32,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
/// Push constants of filter_curvature(1).comp.
pub struct CurvaturePush {
    iters: i32,
    first_iter: i32,
    it_max: i32,
    dt: f32,
    world_radius: f32,
    kappa: f32,
    edge: f32,
}

/// Work-group edge of filter_curvature.comp.
use crate::shader_constants::CURVATURE_LOCAL;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
/// Push constants of filter_bilateral.comp.
pub struct BilateralPush {
    dir: [i32; 2],
    world_radius: f32,
    sigma_range: f32,
    max_px: i32,
}

// Every smoothing program reads one depth image and writes the next ping-pong image in full.
declare_program!(pub BILATERAL: BilateralPush = compute(shaders::FILTER_BILATERAL, [Uniform, ImgRead, ImgOverwrite]));
declare_program!(pub NARROW: NarrowPush = compute(shaders::FILTER_NARROW, [Uniform, ImgRead, ImgOverwrite]));
declare_program!(pub CURVATURE: CurvaturePush = compute(shaders::FILTER_CURVATURE, [Uniform, ImgRead, ImgOverwrite]));
declare_program!(pub CURVATURE1: CurvaturePush = compute(shaders::FILTER_CURVATURE1, [Uniform, ImgRead, ImgOverwrite]));

/// One dispatch of `prog`: read `src`, write `dst`.
fn step<P: bytemuck::Pod>(
    ctx: &mut FrameCtx,
    prog: &ComputeProgram<P>,
    frame: &Buffer,
    (src, dst): (&Image, &Image),
    push: &P,
    local: u32,
) {
    let g = groups_2d(dst.extent.width, dst.extent.height, local);
    prog.dispatch(ctx, &[frame.into(), src.into(), dst.into()], push, g);
}

impl DepthFilter {
    /// Build the pass's pipelines (their slot lists were checked against the shaders at compile time).
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(DepthFilter {
            bilateral: ComputeProgram::new(gpu, &BILATERAL)?,
            narrow: ComputeProgram::new(gpu, &NARROW)?,
            curvature: ComputeProgram::new(gpu, &CURVATURE)?,
            curvature1: ComputeProgram::new(gpu, &CURVATURE1)?,
        })
    }

    /// Smooth `depth` using `a` and `b` as ping-pong images; returns the image holding the result
    /// (`depth` itself when the filter is `None`). `depth` is only read. `cf_iterations_needed`: the largest
    /// adaptive iteration count any pixel can have this frame (F·ρ/d of the nearest particle), see
    /// [`iterations_needed`].
    /// Smooth `depth` with `p.method`, ping-ponging between `pong.0` and `pong.1` (the second may be `depth`
    /// itself when the raw depth need not survive); returns which image holds the result. The pass decides its
    /// own dispatch count: curvature flow stops where no pixel iterates any more (`iterations_needed` from the
    /// frame's focal length and nearest fluid depth).
    #[allow(clippy::too_many_arguments)]
    pub fn record<'a>(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        depth: &'a Image,
        pong: (&'a Image, &'a Image),
        p: &Params,
        radius: f32,
        info: &FrameInfo,
    ) -> Output {
        let its = iterations_needed(p, radius, info.focal_px, info.d_near);
        self.record_iterations(ctx, frame, depth, pong, p, radius, its)
    }

    /// [`DepthFilter::record`] with the curvature-flow iteration count given (tests drive it directly).
    #[allow(clippy::too_many_arguments)]
    pub fn record_iterations<'a>(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        depth: &'a Image,
        pong: (&'a Image, &'a Image),
        p: &Params,
        radius: f32,
        cf_iterations_needed: u32,
    ) -> Output {
        let (a, b) = pong;
        let r = radius;
        // Each dispatch reads `src` and writes the next ping-pong image, which becomes `src`; `out` counts.
        let mut out = Output::Input;
        let mut src = depth;
        let mut next = |src: &mut &'a Image| -> (&'a Image, &'a Image) {
            let (dst, o) = if out == Output::First { (b, Output::Second) } else { (a, Output::First) };
            out = o;
            let pair = (*src, dst);
            *src = dst;
            pair
        };
        if p.method == Filter::None {
            return Output::Input;
        }
        ctx.pass(NAME, |ctx| match p.method {
            Filter::None => {}
            Filter::Gaussian | Filter::Bilateral | Filter::Bilateral2d => {
                let sigma_range = if p.method == Filter::Gaussian { 0.0 } else { p.bilateral.sigma_range * r };
                let dirs: &[[i32; 2]] = if p.method == Filter::Bilateral2d { &[[0, 0]] } else { &[[1, 0], [0, 1]] };
                for _ in 0..p.bilateral.iterations.max(1) {
                    for dir in dirs {
                        let push = BilateralPush {
                            dir: *dir,
                            world_radius: p.radius * r,
                            sigma_range,
                            max_px: p.max_px as i32,
                        };
                        step(ctx, &self.bilateral, frame, next(&mut src), &push, super::LOCAL_2D);
                    }
                }
            }
            Filter::NarrowRange => {
                for _ in 0..p.narrow.iterations.max(1) {
                    for dir in [[1, 0], [0, 1], [0, 0]] {
                        let push = NarrowPush {
                            dir,
                            world_radius: p.narrow.radius * r,
                            threshold: p.narrow.threshold * r,
                            mu: p.narrow.mu * r,
                            max_px: p.max_px as i32,
                            radius_2d: p.narrow.px_2d as i32,
                            skip_background: p.narrow.skip_background as i32,
                        };
                        step(ctx, &self.narrow, frame, next(&mut src), &push, super::LOCAL_2D);
                    }
                }
            }
            Filter::CurvatureFlow => {
                let k = p.curvature.iters_per_dispatch.clamp(1, 4);
                // No pixel iterates more than F·ρ/d_near times: stop dispatching there.
                let total = p.curvature.it_max.min(cf_iterations_needed);
                let mut first = 0;
                while first < total {
                    let iters = k.min(total - first);
                    let push = CurvaturePush {
                        iters: iters as i32,
                        first_iter: first as i32,
                        it_max: p.curvature.it_max as i32,
                        dt: p.curvature.dt,
                        world_radius: p.curvature.radius * r,
                        kappa: p.curvature.kappa,
                        edge: p.curvature.edge * r,
                    };
                    // K = 1: the untiled shader (no shared memory, no halo recomputation).
                    if iters == 1 {
                        step(ctx, &self.curvature1, frame, next(&mut src), &push, super::LOCAL_2D)
                    } else {
                        step(ctx, &self.curvature, frame, next(&mut src), &push, CURVATURE_LOCAL)
                    }
                    first += iters;
                }
            }
        });
        out
    }
}

/// Largest adaptive curvature-flow iteration count of a frame: F·ρ/d for the nearest particle depth `d_near`.
pub fn iterations_needed(p: &Params, radius: f32, focal_px: f32, d_near: f32) -> u32 {
    let its = focal_px * p.curvature.radius * radius / d_near.max(1e-6);
    (its.ceil().max(0.0) as u32).min(p.curvature.it_max)
}

