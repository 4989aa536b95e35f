//! The recording context of one frame: derives and batches the barriers each pass needs from the resources'
//! last accesses, and opens a debug label and a timestamp scope per pass.

use std::sync::Arc;

use ash::vk;

use super::access::{Access, Dependency};
use super::{Buffer, Gpu, Image, Timer};

/// One declared use of a resource by a pass.
pub enum Use<'a> {
    /// An image read or written; `discard`: the pass overwrites all of it, old contents are not needed.
    Image(&'a Image, Access, bool),
    /// A buffer read or written.
    Buffer(&'a Buffer, Access),
}

impl<'a> Use<'a> {
    /// Shorthands.
    pub fn read(img: &'a Image) -> Self {
        Use::Image(img, Access::ComputeRead, false)
    }
    /// Sampled in a compute shader.
    pub fn sampled(img: &'a Image) -> Self {
        Use::Image(img, Access::ComputeSampled, false)
    }
    /// Written in a compute shader, old contents kept.
    pub fn write(img: &'a Image) -> Self {
        Use::Image(img, Access::ComputeWrite, false)
    }
    /// Written in full: the previous contents are dropped.
    pub fn overwrite(img: &'a Image) -> Self {
        Use::Image(img, Access::ComputeWrite, true)
    }
    /// Buffer read in a compute shader.
    pub fn buf_read(b: &'a Buffer) -> Self {
        Use::Buffer(b, Access::ComputeRead)
    }
}

/// A frame (or one-shot) being recorded.
pub struct FrameCtx<'t> {
    /// The device.
    pub gpu: Arc<Gpu>,
    /// The command buffer being recorded.
    pub cmd: vk::CommandBuffer,
    /// Timestamps per pass, when measured.
    pub timer: Option<&'t mut Timer>,
    open: Vec<Option<u32>>,
    /// Barrier batches flushed (for tests and the bench).
    pub barrier_batches: u32,
    /// Every resource this context declared a use of, and whether it wrote it (for the cross-queue waits of
    /// `schedule::derive_waits`).
    pub touches: Vec<super::schedule::Touch>,
    /// The passes count their own work in this recording: programs whose shader has the counting constant
    /// (shaders_glsl/work_count.glsl's WORK_COUNTING) dispatch their counting pipeline
    /// ([`super::pipeline::ProgramCore::pipeline_for`]). Off unless a frame asks
    /// ([`crate::renderer::FrameRequest::count_work`]).
    pub count_work: bool,
    /// The parts of passes ([`FrameCtx::part`]) are timed on their own scopes in this recording: what each of a
    /// pass's dispatches costs on a device (every part's timestamps drain the pipeline, so the pass itself
    /// reads slower then). Off unless a frame or a step asks ([`Measure::time_parts`]).
    pub time_parts: bool,
}

/// What a recording measures beside the passes' times: the passes' own work counts and the parts of passes.
/// The API's measuring hooks (`FrameRequest::count_work` and `time_parts`, `Simulation::time_parts`,
/// `bench --parts`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Measure {
    /// The passes count their own work ([`FrameCtx::count_work`]).
    pub count_work: bool,
    /// Each part of a pass is timed on its own ([`FrameCtx::time_parts`]).
    pub time_parts: bool,
}

impl<'t> FrameCtx<'t> {
    /// Start recording into `cmd`; resets the timer if given.
    pub fn new(gpu: &Arc<Gpu>, cmd: vk::CommandBuffer, mut timer: Option<&'t mut Timer>) -> Self {
        if let Some(t) = timer.as_deref_mut() {
            t.reset(cmd);
        }
        FrameCtx::continuing(gpu, cmd, timer)
    }

    /// Continue a frame in another command buffer: the timer keeps its scopes (it was reset by the frame's
    /// first context, whose command buffer runs earlier on the same queue).
    pub fn continuing(gpu: &Arc<Gpu>, cmd: vk::CommandBuffer, timer: Option<&'t mut Timer>) -> Self {
        FrameCtx {
            gpu: gpu.clone(),
            cmd,
            timer,
            open: vec![],
            barrier_batches: 0,
            touches: vec![],
            count_work: false,
            time_parts: false,
        }
    }

    /// Derive the barriers for `uses` from each resource's last access, record them in ONE
    /// `vkCmdPipelineBarrier2`, and update the resources' states.
    pub fn barrier(&mut self, uses: &[Use]) {
        let mut images = vec![];
        let mut buffers = vec![];
        for u in uses {
            let touch = |handle: u64, write: bool| super::schedule::Touch { resource: handle, write };
            match *u {
                Use::Image(img, access, discard) => {
                    use ash::vk::Handle;
                    let changes_layout = img.state.get().layout != access.info().layout;
                    self.touches.push(touch(img.raw.as_raw(), access.info().writes || discard || changes_layout));
                    let (dep, next) = img.state.get().transition(access, discard);
                    img.state.set(next);
                    if let Some(d) = dep {
                        images.push(image_barrier(img, &d));
                    }
                }
                Use::Buffer(buf, access) => {
                    use ash::vk::Handle;
                    self.touches.push(touch(buf.raw.as_raw(), access.info().writes));
                    let (dep, next) = buf.state.get().buffer_transition(access);
                    buf.state.set(next);
                    if let Some(d) = dep {
                        if !d.src_stage.is_empty() {
                            buffers.push(
                                vk::BufferMemoryBarrier2::default()
                                    .src_stage_mask(d.src_stage)
                                    .src_access_mask(d.src_access)
                                    .dst_stage_mask(d.dst_stage)
                                    .dst_access_mask(d.dst_access)
                                    .buffer(buf.raw)
                                    .offset(0)
                                    .size(vk::WHOLE_SIZE),
                            );
                        }
                    }
                }
            }
        }
        if images.is_empty() && buffers.is_empty() {
            return;
        }
        let dep = vk::DependencyInfo::default().image_memory_barriers(&images).buffer_memory_barriers(&buffers);
        unsafe { self.gpu.device.cmd_pipeline_barrier2(self.cmd, &dep) };
        self.barrier_batches += 1;
    }

    /// Clear all of `img` to `value` (its barrier derived like any other use: a transfer write that drops the
    /// old contents).
    pub fn clear(&mut self, img: &Image, value: vk::ClearColorValue) {
        self.barrier(&[Use::Image(img, Access::TransferDst, true)]);
        unsafe {
            self.gpu.device.cmd_clear_color_image(
                self.cmd,
                img.raw,
                Access::TransferDst.info().layout,
                &value,
                &[Image::color_range()],
            )
        };
    }

    /// Fill all of `buf` with the 32-bit `value` (a transfer write; the buffer needs TRANSFER_DST usage).
    pub fn fill(&mut self, buf: &Buffer, value: u32) {
        self.barrier(&[Use::Buffer(buf, Access::TransferDst)]);
        unsafe { self.gpu.device.cmd_fill_buffer(self.cmd, buf.raw, 0, vk::WHOLE_SIZE, value) };
    }

    /// Fill `size` bytes of `buf` from byte `offset` (both multiples of 4) with the 32-bit `value`.
    pub fn fill_range(&mut self, buf: &Buffer, offset: u64, size: u64, value: u32) {
        self.barrier(&[Use::Buffer(buf, Access::TransferDst)]);
        unsafe { self.gpu.device.cmd_fill_buffer(self.cmd, buf.raw, offset, size, value) };
    }

    /// Copy `size` bytes from `src` to `dst` (offsets in bytes; transfer read and write, barriers derived).
    pub fn copy_buffer(&mut self, src: &Buffer, dst: &Buffer, region: vk::BufferCopy) {
        self.barrier(&[Use::Buffer(src, Access::TransferSrc), Use::Buffer(dst, Access::TransferDst)]);
        if region.size > 0 {
            unsafe { self.gpu.device.cmd_copy_buffer(self.cmd, src.raw, dst.raw, &[region]) };
        }
    }

    /// Open pass `name`: a debug label and a timestamp scope. The pass's barriers come with its dispatches
    /// (derived from each program's slot list), so nothing is declared here; the begin timestamp is written at
    /// ALL_COMMANDS, i.e. after every earlier command finished, wherever the first barrier lands.
    pub fn begin_pass(&mut self, name: &str) {
        self.gpu.begin_label(self.cmd, name);
        let q = self.timer.as_deref_mut().and_then(|t| t.begin(self.cmd, name));
        self.open.push(q);
    }

    /// Close the innermost open pass.
    pub fn end_pass(&mut self) {
        if let Some(q) = self.open.pop() {
            if let (Some(q), Some(t)) = (q, self.timer.as_deref_mut()) {
                t.end(self.cmd, q);
            }
            self.gpu.end_label(self.cmd);
        }
    }

    /// `begin_pass`, `f`, `end_pass`.
    pub fn pass<R>(&mut self, name: &str, f: impl FnOnce(&mut Self) -> R) -> R {
        self.begin_pass(name);
        let r = f(self);
        self.end_pass();
        r
    }

    /// A part of the open pass (`name` = "pass/part"), timed on its own scope when the recording asks
    /// ([`FrameCtx::time_parts`]), else simply `f`. Parts are not passes: frame totals and per-queue sums leave
    /// them out ([`super::PassTimes::total`], [`is_part`]).
    pub fn part<R>(&mut self, name: &str, f: impl FnOnce(&mut Self) -> R) -> R {
        if self.time_parts {
            self.pass(name, f)
        } else {
            f(self)
        }
    }
}

fn image_barrier(img: &Image, d: &Dependency) -> vk::ImageMemoryBarrier2<'static> {
    // A barrier with no earlier stage (first use) still carries the layout transition.
    let src_stage = if d.src_stage.is_empty() { vk::PipelineStageFlags2::NONE } else { d.src_stage };
    vk::ImageMemoryBarrier2::default()
        .src_stage_mask(src_stage)
        .src_access_mask(d.src_access)
        .dst_stage_mask(d.dst_stage)
        .dst_access_mask(d.dst_access)
        .old_layout(d.old_layout)
        .new_layout(d.new_layout)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(img.raw)
        .subresource_range(img.range())
}
