//! Where a frame is recorded: one command buffer, or one per part of a frame split over the main and the async
//! compute queue — the background and thickness beside the fluid's passes, the shading after both.

use crate::gpu::FrameCtx;

/// Which part of the frame a pass belongs to: the async compute part (the static background and the
/// thickness: they depend on nothing the fluid passes write), the fluid part, and the shading part (it reads
/// both). In a one-queue frame all three are one command buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// Async compute queue (when split).
    Async,
    /// Main queue: the fluid's depth, smoothing and normals.
    Fluid,
    /// Main queue, after the async part: reflections and shading.
    Shade,
}

/// Where `record_frame` records: one context, or one per part (a split, two-queue frame).
pub enum Recording<'a, 't> {
    /// Everything in one command buffer.
    One(&'a mut FrameCtx<'t>),
    /// One command buffer per part.
    Split {
        /// [`Part::Async`].
        async_part: &'a mut FrameCtx<'t>,
        /// [`Part::Fluid`].
        fluid: &'a mut FrameCtx<'t>,
        /// [`Part::Shade`].
        shade: &'a mut FrameCtx<'t>,
    },
}

impl<'t> Recording<'_, 't> {
    /// The context of part `p`.
    pub fn part(&mut self, p: Part) -> &mut FrameCtx<'t> {
        match self {
            Recording::One(c) => c,
            Recording::Split { async_part, fluid, shade } => match p {
                Part::Async => async_part,
                Part::Fluid => fluid,
                Part::Shade => shade,
            },
        }
    }
}
