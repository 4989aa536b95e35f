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

use super::{Gpu, PassTimes, Timer};
use crate::error::{Result, VkContext};

/// One frame slot.
pub struct Slot {
    pool: vk::CommandPool,
    /// The slot's command buffer (reset when the slot starts a frame).
    pub cmd: vk::CommandBuffer,
    /// The slot's timestamp pool.
    pub timer: Timer,
    /// Timeline value the slot's last submission signals (0: never submitted).
    pub value: u64,
}

/// N frames in flight on the main queue.
pub struct Executor {
    gpu: Arc<Gpu>,
    timeline: vk::Semaphore,
    submitted: u64,
    slots: Vec<Slot>,
    next: usize,
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
        gpu.name_object(timeline, "frame timeline");
        let mut ex = Executor { gpu: gpu.clone(), timeline, submitted: 0, slots: vec![], next: 0 };
        for _ in 0..frames.max(1) {
            let pool_ci = vk::CommandPoolCreateInfo::default()
                .queue_family_index(gpu.queues.main.family)
                .flags(vk::CommandPoolCreateFlags::TRANSIENT);
            let pool = unsafe { d.create_command_pool(&pool_ci, None) }.vk("vkCreateCommandPool")?;
            let ai = vk::CommandBufferAllocateInfo::default()
                .command_pool(pool)
                .level(vk::CommandBufferLevel::PRIMARY)
                .command_buffer_count(1);
            let cmd = match unsafe { d.allocate_command_buffers(&ai) }.vk("vkAllocateCommandBuffers") {
                Ok(c) => c[0],
                Err(e) => {
                    unsafe { d.destroy_command_pool(pool, None) };
                    return Err(e);
                }
            };
            ex.slots.push(Slot { pool, cmd, timer: Timer::new(gpu)?, value: 0 });
        }
        Ok(ex)
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
        let times = if previous > 0 {
            self.wait(previous)?;
            Some(self.slots[k].timer.read()?)
        } else {
            None
        };
        let d = &self.gpu.device;
        let s = &self.slots[k];
        unsafe { d.reset_command_pool(s.pool, vk::CommandPoolResetFlags::empty()) }.vk("vkResetCommandPool")?;
        let bi = vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        unsafe { d.begin_command_buffer(s.cmd, &bi) }.vk("vkBeginCommandBuffer")?;
        Ok((k, times))
    }

    /// The slot `k`.
    pub fn slot(&mut self, k: usize) -> &mut Slot {
        &mut self.slots[k]
    }

    /// End slot `k`'s command buffer and submit it on the main queue, signalling the next timeline value.
    pub fn submit(&mut self, k: usize) -> Result<Submitted> {
        let d = &self.gpu.device;
        let s = &mut self.slots[k];
        unsafe { d.end_command_buffer(s.cmd) }.vk("vkEndCommandBuffer")?;
        let value = self.submitted + 1;
        let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(s.cmd)];
        let signal = [vk::SemaphoreSubmitInfo::default()
            .semaphore(self.timeline)
            .value(value)
            .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)];
        let submit = [vk::SubmitInfo2::default().command_buffer_infos(&cmds).signal_semaphore_infos(&signal)];
        unsafe { d.queue_submit2(self.gpu.queues.main.queue, &submit, vk::Fence::null()) }.vk("vkQueueSubmit2")?;
        self.submitted = value;
        s.value = value;
        Ok(Submitted { slot: k, value })
    }

    /// Wait on the host until timeline value `value` is signalled.
    pub fn wait(&self, value: u64) -> Result<()> {
        let sems = [self.timeline];
        let values = [value];
        let wi = vk::SemaphoreWaitInfo::default().semaphores(&sems).values(&values);
        unsafe { self.gpu.device.wait_semaphores(&wi, u64::MAX) }.vk("vkWaitSemaphores")
    }

    /// Wait for every frame submitted so far.
    pub fn wait_idle(&self) -> Result<()> {
        if self.submitted > 0 {
            self.wait(self.submitted)?;
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
            }
            d.destroy_semaphore(self.timeline, None);
        }
    }
}
