//! Tests of gpu/queues.rs: the choice of the async compute queue from the queue families.

use super::*;

fn family(flags: vk::QueueFlags, count: u32, ts: u32) -> vk::QueueFamilyProperties {
    vk::QueueFamilyProperties { queue_flags: flags, queue_count: count, timestamp_valid_bits: ts, ..Default::default() }
}

/// A compute-only family wins (and needs timestamps); else a second queue of the main family; else the
/// main queue itself (lavapipe).
#[test]
fn async_queue_choice() {
    use vk::QueueFlags as F;
    let gfx = F::GRAPHICS | F::COMPUTE | F::TRANSFER;
    let nvidia = [family(gfx, 16, 64), family(F::TRANSFER, 2, 64), family(F::COMPUTE | F::TRANSFER, 8, 64)];
    assert_eq!(choose_async_queue(&nvidia, 0), (2, 0, AsyncQueue::ComputeFamily));
    let no_ts = [family(gfx, 4, 64), family(F::COMPUTE, 2, 0)];
    assert_eq!(choose_async_queue(&no_ts, 0), (0, 1, AsyncQueue::SecondQueue));
    let lavapipe = [family(gfx, 1, 64)];
    assert_eq!(choose_async_queue(&lavapipe, 0), (0, 0, AsyncQueue::SameQueue));
}
