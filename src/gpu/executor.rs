//! The frame executor: N frames in flight on the main queue. Each slot owns a command pool and buffer, a
//! timestamp pool and whatever per-frame host-written memory the renderer keeps beside it; one timeline
//! semaphore orders everything. Starting a frame in a slot waits (on the host, on the timeline) only for the
//! frame that last used that slot — N frames back — and reads that frame's timestamps then, a frame late,
//! without a query wait. There is no device or queue wait in the steady state.
//!
//! Frames in flight share the frame's images: on one queue, submission order plus the barriers derived from
//! each resource's last access (whose first scope covers earlier submissions) keep them correct, and the
//! synchronization validation layer checks exactly that in the tests.

use std::sync::Arc;

use ash::vk;

use super::recording::Recording;
use super::{FrameCtx, Gpu, Timer};
use crate::error::{Result, VkContext};
use crate::timing::PassTimes;

/// Command buffers of one slot on the main queue (a one-queue frame uses the first; a split frame uses
/// three: upload, fluid, shade) and on the async compute queue (one).
pub const MAIN_SEGMENTS: usize = 3;

/// One frame slot.
pub struct SlotCommands {
    pool: vk::CommandPool,
    compute_pool: vk::CommandPool,
    /// The slot's command buffer (reset when the slot starts a frame): the first main segment.
    pub cmd: vk::CommandBuffer,
    /// Further main-queue segments of a split frame.
    pub main_cmds: [vk::CommandBuffer; MAIN_SEGMENTS],
    /// The async compute segments of a split frame: [particle upload, passes].
    pub compute_cmds: [vk::CommandBuffer; 2],
    /// The slot's timestamp pool (the first main segment).
    pub timer: Timer,
    /// Timestamp pools of the other segments of a split frame: [async, fluid, shade].
    pub segment_timers: [Timer; 3],
    /// Whether the slot's last frame was split over two queues (its times are in `segment_timers` too).
    pub split: bool,
    /// Timeline values the slot's last frame signals on the main and the compute timeline (0: none).
    pub value: u64,
    compute_value: u64,
}

/// N frames in flight on the main queue (and, for split frames, on the async compute queue).
pub struct Executor {
    gpu: Arc<Gpu>,
    /// The segments of the last submitted frame: queue, what it touched, the timeline value it signals — the
    /// next frame's waits are derived against them too (cross-frame hazards, e.g. the next frame's upload into
    /// the particle buffer the frame before last read).
    /// (The last `frames − 1` frames: any older one is complete once `begin` waited for its slot.)
    previous: std::collections::VecDeque<Vec<(super::schedule::QueueId, Vec<super::schedule::Touch>, u64)>>,
    timeline: vk::Semaphore,
    compute_timeline: vk::Semaphore,
    submitted: u64,
    compute_submitted: u64,
    slots: Vec<SlotCommands>,
    next: usize,
}

/// Binary semaphores a frame's submission waits for (with the stage that waits) and signals.
#[derive(Clone, Copy, Debug, Default)]
pub struct Binary {
    /// Wait for this semaphore before `stage`.
    pub wait: Option<(vk::Semaphore, vk::PipelineStageFlags2)>,
    /// Signal this semaphore when the frame is done.
    pub signal: Option<vk::Semaphore>,
}

/// One timed scope of a frame.
#[derive(Clone, Debug)]
pub struct Span {
    /// Pass name.
    pub name: String,
    /// The queue it ran on.
    pub queue: super::schedule::QueueId,
    /// Begin, device clock, ns.
    pub begin_ns: f64,
    /// End, device clock, ns.
    pub end_ns: f64,
    /// Compute shader invocations it ran (a pipeline-statistics query; None where the device has none, or for a
    /// scope inside another, whose invocations its parent counts).
    pub invocations: Option<u64>,
}

/// One segment of a split frame, in recording (= valid serial) order.
#[derive(Clone, Debug)]
pub struct Segment {
    /// Its queue.
    pub queue: super::schedule::QueueId,
    /// Its command buffer (recorded, not yet ended).
    pub cmd: vk::CommandBuffer,
    /// What it touched (from its `FrameCtx`).
    pub touches: Vec<super::schedule::Touch>,
}

/// What a slot recorded: its one command buffer and what it touched, or a split frame's segments.
pub enum Recorded {
    /// One command buffer on the main queue.
    One(Vec<super::schedule::Touch>),
    /// The split frame's segments, in submission order.
    Split(Vec<Segment>),
}

impl SlotCommands {
    /// Record a frame into this slot's command buffers (one, or the split frame's five when `self.split`):
    /// `upload` first (the particles' copy and a producer's work: the async queue's first segment when split),
    /// then the frame's passes through `passes` (one [`Recording`], or the split one: the async part, the fluid,
    /// the shading), then `finish` in the frame's last command buffer (the caller's after-work, the read-back).
    /// The queue segments — which command buffer, on which queue, with what it touched — are assembled here;
    /// [`Executor::submit_recorded`] submits them. `measure`: the passes' work counts and parts
    /// ([`super::context::Measure`]).
    pub fn record<R>(
        &mut self,
        gpu: &Arc<Gpu>,
        measure: super::context::Measure,
        upload: impl FnOnce(&mut FrameCtx),
        passes: impl FnOnce(&mut Recording) -> Result<R>,
        finish: impl FnOnce(&mut FrameCtx, &R),
    ) -> Result<(R, Recorded)> {
        use super::schedule::QueueId;
        if !self.split {
            let mut ctx = FrameCtx::new(gpu, self.cmd, Some(&mut self.timer));
            (ctx.count_work, ctx.time_parts) = (measure.count_work, measure.time_parts);
            upload(&mut ctx);
            let r = passes(&mut Recording::One(&mut ctx))?;
            finish(&mut ctx, &r);
            return Ok((r, Recorded::One(std::mem::take(&mut ctx.touches))));
        }
        // A split frame: the particle upload (async) ‖ the previous frame's passes; background + thickness
        // (async) ‖ the fluid passes (main); shading (main) after both. The waits between the queues — within
        // this frame and against the frame before — come from what each segment touched.
        let (main_cmds, compute_cmds) = (self.main_cmds, self.compute_cmds);
        let [ta, tf, tsh] = &mut self.segment_timers;
        // The first main command buffer only resets the main timer (it began with the slot).
        let mut first = FrameCtx::new(gpu, main_cmds[0], Some(&mut self.timer));
        // The async part's timer starts in the upload's command buffer (it runs first on that queue), so a
        // simulation step recorded there is timed with the async passes.
        let mut up = FrameCtx::new(gpu, compute_cmds[0], Some(ta));
        up.time_parts = measure.time_parts;
        upload(&mut up);
        let up_touches = std::mem::take(&mut up.touches);
        let ta = up.timer.take().expect("given");
        drop(up);
        let mut a = FrameCtx::continuing(gpu, compute_cmds[1], Some(ta));
        let mut f = FrameCtx::new(gpu, main_cmds[1], Some(tf));
        let mut sh = FrameCtx::new(gpu, main_cmds[2], Some(tsh));
        for c in [&mut a, &mut f, &mut sh] {
            (c.count_work, c.time_parts) = (measure.count_work, measure.time_parts);
        }
        let r = passes(&mut Recording::Split { async_part: &mut a, fluid: &mut f, shade: &mut sh })?;
        finish(&mut sh, &r);
        let segment =
            |queue, cmd, ctx: &mut FrameCtx| Segment { queue, cmd, touches: std::mem::take(&mut ctx.touches) };
        Ok((
            r,
            Recorded::Split(vec![
                segment(QueueId::Main, main_cmds[0], &mut first),
                Segment { queue: QueueId::Compute, cmd: compute_cmds[0], touches: up_touches },
                segment(QueueId::Compute, compute_cmds[1], &mut a),
                segment(QueueId::Main, main_cmds[1], &mut f),
                segment(QueueId::Main, main_cmds[2], &mut sh),
            ]),
        ))
    }
}

/// A frame handed to the GPU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Submitted {
    /// The slot it was recorded in.
    pub slot: usize,
    /// The timeline value that signals its completion.
    pub value: u64,
}

impl Executor {
    /// `frames` slots (at least 1).
    pub fn new(gpu: &Arc<Gpu>, frames: usize) -> Result<Executor> {
        let d = &gpu.device;
        let mut type_ci = vk::SemaphoreTypeCreateInfo::default().semaphore_type(vk::SemaphoreType::TIMELINE);
        let ci = vk::SemaphoreCreateInfo::default().push_next(&mut type_ci);
        let timeline = unsafe { d.create_semaphore(&ci, None) }.vk("vkCreateSemaphore")?;
        let compute_timeline = match unsafe { d.create_semaphore(&ci, None) }.vk("vkCreateSemaphore") {
            Ok(t) => t,
            Err(e) => {
                unsafe { d.destroy_semaphore(timeline, None) };
                return Err(e);
            }
        };
        gpu.name_object(timeline, "main timeline");
        gpu.name_object(compute_timeline, "compute timeline");
        let mut ex = Executor {
            gpu: gpu.clone(),
            timeline,
            compute_timeline,
            submitted: 0,
            compute_submitted: 0,
            previous: Default::default(),
            slots: vec![],
            next: 0,
        };
        let pool = |family: u32| -> Result<vk::CommandPool> {
            let ci = vk::CommandPoolCreateInfo::default()
                .queue_family_index(family)
                .flags(vk::CommandPoolCreateFlags::TRANSIENT);
            unsafe { d.create_command_pool(&ci, None) }.vk("vkCreateCommandPool")
        };
        let alloc = |pool: vk::CommandPool, n: u32| -> Result<Vec<vk::CommandBuffer>> {
            let ai = vk::CommandBufferAllocateInfo::default()
                .command_pool(pool)
                .level(vk::CommandBufferLevel::PRIMARY)
                .command_buffer_count(n);
            unsafe { d.allocate_command_buffers(&ai) }.vk("vkAllocateCommandBuffers")
        };
        for _ in 0..frames.max(1) {
            let main_pool = pool(gpu.queues.main.family)?;
            let compute_pool = match pool(gpu.queues.compute.family) {
                Ok(p) => p,
                Err(e) => {
                    unsafe { d.destroy_command_pool(main_pool, None) };
                    return Err(e);
                }
            };
            // From here the slot owns both pools (destroyed with the executor, even on an error below).
            ex.slots.push(SlotCommands {
                pool: main_pool,
                compute_pool,
                cmd: vk::CommandBuffer::null(),
                main_cmds: [vk::CommandBuffer::null(); MAIN_SEGMENTS],
                compute_cmds: [vk::CommandBuffer::null(); 2],
                timer: Timer::new(gpu)?,
                segment_timers: [Timer::new(gpu)?, Timer::new(gpu)?, Timer::new(gpu)?],
                split: false,
                value: 0,
                compute_value: 0,
            });
            let s = ex.slots.last_mut().expect("pushed");
            let main = alloc(main_pool, MAIN_SEGMENTS as u32)?;
            s.cmd = main[0];
            s.main_cmds.copy_from_slice(&main);
            s.compute_cmds.copy_from_slice(&alloc(compute_pool, 2)?);
        }
        Ok(ex)
    }

    /// The GPU times of slot `k`'s last frame (every part of a split frame), in recording order.
    pub fn times(&mut self, k: usize) -> Result<PassTimes> {
        let s = &self.slots[k];
        let mut all = s.timer.read()?.0;
        if s.split {
            for t in &s.segment_timers {
                all.extend(t.read()?.0);
            }
        }
        Ok(PassTimes(all))
    }

    /// Every timed scope of slot `k`'s last frame with its queue, begin and end (ns, device clock).
    pub fn spans(&mut self, k: usize) -> Result<Vec<Span>> {
        use super::schedule::QueueId;
        let s = &self.slots[k];
        let mut out: Vec<Span> = s
            .timer
            .spans()?
            .into_iter()
            .map(|(name, b, e, n)| Span { name, queue: QueueId::Main, begin_ns: b, end_ns: e, invocations: n })
            .collect();
        if s.split {
            for (t, q) in s.segment_timers.iter().zip([QueueId::Compute, QueueId::Main, QueueId::Main]) {
                out.extend(t.spans()?.into_iter().map(|(name, b, e, n)| Span {
                    name,
                    queue: q,
                    begin_ns: b,
                    end_ns: e,
                    invocations: n,
                }));
            }
        }
        Ok(out)
    }

    /// The slot the next frame will use.
    pub fn next_slot(&self) -> usize {
        self.next
    }

    /// Frames in flight.
    pub fn frames(&self) -> usize {
        self.slots.len()
    }

    /// Start a frame: take the next slot, wait until the frame that last used it completed, read that frame's
    /// timestamps (returned: a frame late), reset the slot and begin its command buffer.
    pub fn begin(&mut self) -> Result<(usize, Option<PassTimes>)> {
        let k = self.next;
        self.next = (self.next + 1) % self.slots.len();
        let previous = self.slots[k].value;
        if self.slots[k].compute_value > 0 {
            self.wait_compute(self.slots[k].compute_value)?;
        }
        let times = if previous > 0 {
            self.wait(previous)?;
            Some(self.times(k)?)
        } else {
            None
        };
        let d = &self.gpu.device;
        let s = &mut self.slots[k];
        s.compute_value = 0;
        unsafe {
            d.reset_command_pool(s.pool, vk::CommandPoolResetFlags::empty()).vk("vkResetCommandPool")?;
            d.reset_command_pool(s.compute_pool, vk::CommandPoolResetFlags::empty()).vk("vkResetCommandPool")?;
        }
        let bi = vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        unsafe { d.begin_command_buffer(s.cmd, &bi) }.vk("vkBeginCommandBuffer")?;
        Ok((k, times))
    }

    /// Begin the other command buffers of slot `k` for a split frame (the first main one began in `begin`).
    pub fn begin_split(&mut self, k: usize) -> Result<()> {
        let d = &self.gpu.device;
        let s = &self.slots[k];
        let bi = vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        for &c in s.main_cmds[1..].iter().chain(s.compute_cmds.iter()) {
            unsafe { d.begin_command_buffer(c, &bi) }.vk("vkBeginCommandBuffer")?;
        }
        Ok(())
    }

    /// End and submit the segments of a split frame in slot `k`, in order. Each signals its queue's timeline and
    /// waits for the segments of the other queue it conflicts with — in this frame or in the frame submitted
    /// before (`schedule::derive_waits` over both; anything older is complete, `begin` waited for it).
    ///
    /// `binary` (a swapchain's acquire and render-finished semaphores) is waited for and signalled by the last
    /// segment, which must be on the main queue (it writes and hands over the swapchain image).
    pub fn submit_segments(&mut self, k: usize, segments: Vec<Segment>, binary: &Binary) -> Result<Submitted> {
        use super::schedule::{derive_waits, QueueId};
        let d = &self.gpu.device;
        let prev: Vec<_> = self.previous.iter().flatten().cloned().collect();
        let all: Vec<(QueueId, Vec<super::schedule::Touch>)> = prev
            .iter()
            .map(|(q, t, _)| (*q, t.clone()))
            .chain(segments.iter().map(|s| (s.queue, s.touches.clone())))
            .collect();
        let waits = derive_waits(&all);
        let mut values: Vec<(QueueId, u64)> = prev.iter().map(|(q, _, v)| (*q, *v)).collect();
        let sem_of = |q: QueueId, t: &Self| if q == QueueId::Main { t.timeline } else { t.compute_timeline };
        for (j, seg) in segments.iter().enumerate() {
            unsafe { d.end_command_buffer(seg.cmd) }.vk("vkEndCommandBuffer")?;
            let (queue, value) = match seg.queue {
                QueueId::Main => {
                    self.submitted += 1;
                    (self.gpu.queues.main.queue, self.submitted)
                }
                QueueId::Compute => {
                    self.compute_submitted += 1;
                    (self.gpu.queues.compute.queue, self.compute_submitted)
                }
            };
            let last = j + 1 == segments.len();
            if last && seg.queue != QueueId::Main && (binary.wait.is_some() || binary.signal.is_some()) {
                return Err(crate::error::Error::Invalid("a presenting split frame must end on the main queue".into()));
            }
            let mut wait_infos: Vec<vk::SemaphoreSubmitInfo> = waits[prev.len() + j]
                .iter()
                .map(|&i| {
                    let (q, v) = values[i];
                    vk::SemaphoreSubmitInfo::default()
                        .semaphore(sem_of(q, self))
                        .value(v)
                        .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
                })
                .collect();
            values.push((seg.queue, value));
            let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(seg.cmd)];
            let mut signal = vec![vk::SemaphoreSubmitInfo::default()
                .semaphore(sem_of(seg.queue, self))
                .value(value)
                .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)];
            if last {
                if let Some((sem, stage)) = binary.wait {
                    wait_infos.push(vk::SemaphoreSubmitInfo::default().semaphore(sem).stage_mask(stage));
                }
                if let Some(sem) = binary.signal {
                    signal.push(
                        vk::SemaphoreSubmitInfo::default()
                            .semaphore(sem)
                            .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS),
                    );
                }
            }
            let submit = [vk::SubmitInfo2::default()
                .wait_semaphore_infos(&wait_infos)
                .command_buffer_infos(&cmds)
                .signal_semaphore_infos(&signal)];
            unsafe { d.queue_submit2(queue, &submit, vk::Fence::null()) }.vk("vkQueueSubmit2")?;
        }
        let done = segments.into_iter().zip(values[prev.len()..].iter()).map(|(seg, (q, v))| (*q, seg.touches, *v));
        self.remember(done.collect());
        let s = &mut self.slots[k];
        s.value = self.submitted;
        s.compute_value = self.compute_submitted;
        Ok(Submitted { slot: k, value: self.submitted })
    }

    /// Keep a submitted frame's segments for the next frames' waits (at most `frames − 1` frames).
    fn remember(&mut self, frame: Vec<(super::schedule::QueueId, Vec<super::schedule::Touch>, u64)>) {
        self.previous.push_back(frame);
        while self.previous.len() > self.slots.len().saturating_sub(1) {
            self.previous.pop_front();
        }
    }

    /// Wait on the host until the compute timeline reaches `value`.
    fn wait_compute(&self, value: u64) -> Result<()> {
        let sems = [self.compute_timeline];
        let values = [value];
        let wi = vk::SemaphoreWaitInfo::default().semaphores(&sems).values(&values);
        unsafe { self.gpu.device.wait_semaphores(&wi, u64::MAX) }.vk("vkWaitSemaphores")
    }

    /// Submit what slot `k` recorded ([`SlotCommands::record`]): one command buffer, or the split frame's
    /// segments with the waits between the queues derived from what each touched.
    pub fn submit_recorded(&mut self, k: usize, recorded: Recorded, binary: &Binary) -> Result<Submitted> {
        match recorded {
            Recorded::One(touches) => self.submit_one(k, binary, touches),
            Recorded::Split(segments) => self.submit_segments(k, segments, binary),
        }
    }

    /// The slot `k`.
    pub fn slot(&mut self, k: usize) -> &mut SlotCommands {
        &mut self.slots[k]
    }

    /// End slot `k`'s command buffer and submit it on the main queue, signalling the next timeline value.
    pub fn submit(&mut self, k: usize) -> Result<Submitted> {
        self.submit_with(k, &Binary::default())
    }

    /// [`Executor::submit`] that also waits for and signals binary semaphores (a swapchain's acquire and
    /// render-finished semaphores: the frame and its present in one submit).
    pub fn submit_with(&mut self, k: usize, binary: &Binary) -> Result<Submitted> {
        self.submit_one(k, binary, vec![])
    }

    /// [`Executor::submit_with`], remembering what the frame touched (for the next split frame's waits).
    pub fn submit_one(&mut self, k: usize, binary: &Binary, touches: Vec<super::schedule::Touch>) -> Result<Submitted> {
        let d = &self.gpu.device;
        let s = &mut self.slots[k];
        unsafe { d.end_command_buffer(s.cmd) }.vk("vkEndCommandBuffer")?;
        let value = self.submitted + 1;
        let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(s.cmd)];
        let mut signal = vec![vk::SemaphoreSubmitInfo::default()
            .semaphore(self.timeline)
            .value(value)
            .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)];
        if let Some(sem) = binary.signal {
            signal.push(
                vk::SemaphoreSubmitInfo::default().semaphore(sem).stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS),
            );
        }
        let waits: Vec<vk::SemaphoreSubmitInfo> = binary
            .wait
            .iter()
            .map(|&(sem, stage)| vk::SemaphoreSubmitInfo::default().semaphore(sem).stage_mask(stage))
            .collect();
        let submit = [vk::SubmitInfo2::default()
            .wait_semaphore_infos(&waits)
            .command_buffer_infos(&cmds)
            .signal_semaphore_infos(&signal)];
        unsafe { d.queue_submit2(self.gpu.queues.main.queue, &submit, vk::Fence::null()) }.vk("vkQueueSubmit2")?;
        self.submitted = value;
        s.value = value;
        self.remember(vec![(super::schedule::QueueId::Main, touches, value)]);
        Ok(Submitted { slot: k, value })
    }

    /// Wait on the host until timeline value `value` is signalled.
    pub fn wait(&self, value: u64) -> Result<()> {
        let sems = [self.timeline];
        let values = [value];
        let wi = vk::SemaphoreWaitInfo::default().semaphores(&sems).values(&values);
        unsafe { self.gpu.device.wait_semaphores(&wi, u64::MAX) }.vk("vkWaitSemaphores")
    }

    /// Wait for the frames in flight, then replace `slot` with what `make` builds (None: free it). A technique's
    /// or an effect's frame resources change only through here, so no frame in flight loses an image it uses.
    pub fn replace<T>(&self, slot: &mut Option<T>, make: impl FnOnce() -> Result<Option<T>>) -> Result<()> {
        self.wait_idle()?;
        *slot = None;
        *slot = make()?;
        Ok(())
    }

    /// Wait for every frame submitted so far, on both queues.
    pub fn wait_idle(&self) -> Result<()> {
        if self.submitted > 0 {
            self.wait(self.submitted)?;
        }
        if self.compute_submitted > 0 {
            self.wait_compute(self.compute_submitted)?;
        }
        Ok(())
    }

    /// Wait for everything slot `k`'s last frame submitted (both queues).
    pub fn wait_slot(&self, k: usize) -> Result<()> {
        let s = &self.slots[k];
        if s.compute_value > 0 {
            self.wait_compute(s.compute_value)?;
        }
        if s.value > 0 {
            self.wait(s.value)?;
        }
        Ok(())
    }

    /// Whether any submitted frame may still run.
    pub fn busy(&self) -> Result<bool> {
        let v =
            unsafe { self.gpu.device.get_semaphore_counter_value(self.timeline) }.vk("vkGetSemaphoreCounterValue")?;
        Ok(v < self.submitted)
    }
}

impl Drop for Executor {
    fn drop(&mut self) {
        let _ = self.wait_idle();
        let d = &self.gpu.device;
        unsafe {
            for s in &self.slots {
                d.destroy_command_pool(s.pool, None);
                d.destroy_command_pool(s.compute_pool, None);
            }
            d.destroy_semaphore(self.timeline, None);
            d.destroy_semaphore(self.compute_timeline, None);
        }
    }
}
