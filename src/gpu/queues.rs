//! The device's queues: the frame's graphics + compute queue and the async compute queue, and how the latter is
//! chosen from the queue families (a compute-only family with timestamps, else a second queue of the main
//! family, else the main queue itself).

use ash::vk;

/// How the async compute queue relates to the main one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum AsyncQueue {
    /// A queue of a compute-only family (true async compute).
    ComputeFamily,
    /// A second queue of the main (graphics + compute) family.
    SecondQueue,
    /// The main queue itself (lavapipe: one family, one queue): async work is ordered after the frame's.
    SameQueue,
}

/// One queue the device was created with.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct QueueRef {
    /// Queue family index.
    pub family: u32,
    /// Queue index within the family.
    pub index: u32,
    /// The queue.
    #[serde(skip)]
    pub queue: vk::Queue,
}

/// The queues chosen at device creation: the frame's graphics + compute queue and the async compute queue
/// (a compute-only family when the device has one, else a second queue of the main family, else the main
/// queue itself).
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct Queues {
    /// Graphics + compute + transfer: the frame.
    pub main: QueueRef,
    /// Async compute.
    pub compute: QueueRef,
    /// Which of the three choices `compute` is.
    pub kind: AsyncQueue,
}

impl Queues {
    /// One line for `meniscus info --device` and reports.
    pub fn describe(&self) -> String {
        let q = |r: &QueueRef| format!("family {} queue {}", r.family, r.index);
        format!("main: {}; async compute: {} ({:?})", q(&self.main), q(&self.compute), self.kind)
    }
}

/// The async compute queue for main family `main`: (family, index, kind) — a compute-only family with
/// timestamps, else a second queue of the main family, else the main queue.
pub fn choose_async_queue(families: &[vk::QueueFamilyProperties], main: u32) -> (u32, u32, AsyncQueue) {
    let compute_family = families.iter().position(|f| {
        f.queue_flags.contains(vk::QueueFlags::COMPUTE)
            && !f.queue_flags.contains(vk::QueueFlags::GRAPHICS)
            && f.timestamp_valid_bits > 0
    });
    match compute_family {
        Some(cf) => (cf as u32, 0, AsyncQueue::ComputeFamily),
        None if families[main as usize].queue_count >= 2 => (main, 1, AsyncQueue::SecondQueue),
        None => (main, 0, AsyncQueue::SameQueue),
    }
}

#[cfg(test)]
mod tests;
