//! Which semaphore waits a multi-queue frame needs, derived from what each recorded segment touched — the
//! cross-queue half of the access table. A frame is recorded as segments (one command buffer each), each on a
//! queue, in an order that is a valid serial execution; within a queue, submission order and the pipeline
//! barriers derived by `FrameCtx` already synchronise. Between queues only a semaphore does: segment j must
//! wait for an earlier segment i of ANOTHER queue when they touch a common resource and at least one of them
//! writes it (read-after-write, write-after-read, write-after-write). Of several such i on one queue only the
//! latest is kept (its queue runs them in order). Pure: unit-tested without a GPU.
//!
//! Resources shared by two queue families are created with concurrent sharing (see `Gpu::sharing`), so no
//! ownership release/acquire pair is needed: the semaphore is the whole dependency, and the barrier the
//! reading queue derives after its wait only changes the image layout.

/// A queue of the frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum QueueId {
    /// Graphics + compute: the frame's passes.
    Main,
    /// Async compute: work that does not depend on the main queue's passes in flight.
    Compute,
}

/// A resource a segment touched: its handle (raw Vulkan handle) and whether the segment wrote it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Touch {
    /// Raw Vulkan handle of the image or buffer.
    pub resource: u64,
    /// Written (or laid out anew) by the segment.
    pub write: bool,
}

/// For each segment (in recording order), the earlier segments of other queues it must wait for.
pub fn derive_waits(segments: &[(QueueId, Vec<Touch>)]) -> Vec<Vec<usize>> {
    segments
        .iter()
        .enumerate()
        .map(|(j, (qj, tj))| {
            let mut waits: Vec<usize> = vec![];
            for (i, (qi, ti)) in segments[..j].iter().enumerate() {
                if qi == qj {
                    continue;
                }
                let conflict = tj.iter().any(|a| ti.iter().any(|b| a.resource == b.resource && (a.write || b.write)));
                if conflict {
                    // Keep only the latest segment of that queue.
                    waits.retain(|&w| segments[w].0 != *qi);
                    waits.push(i);
                }
            }
            waits
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(resource: u64, write: bool) -> Touch {
        Touch { resource, write }
    }

    /// The frame's async schedule: M1 uploads particles (1), A reads them and writes the background (2) and
    /// thickness (3), M2 reads particles and writes depth (4), M3 reads background, thickness and depth.
    #[test]
    fn async_frame_waits() {
        use QueueId::*;
        let segs = vec![
            (Main, vec![t(1, true)]),
            (Compute, vec![t(1, false), t(2, true), t(3, true)]),
            (Main, vec![t(1, false), t(4, true)]),
            (Main, vec![t(2, false), t(3, false), t(4, false), t(5, true)]),
        ];
        assert_eq!(derive_waits(&segs), vec![vec![], vec![0], vec![], vec![1]]);
    }

    /// Reads on both queues need nothing; a write after a read on the other queue does (WAR); of two
    /// conflicting segments of one queue only the later is waited for.
    #[test]
    fn read_read_is_free_war_and_latest_only() {
        use QueueId::*;
        let segs = vec![
            (Main, vec![t(7, false)]),
            (Main, vec![t(8, true)]),
            (Compute, vec![t(7, false)]),
            (Compute, vec![t(7, true), t(8, false)]),
        ];
        assert_eq!(derive_waits(&segs), vec![vec![], vec![], vec![], vec![1]]);
        let war = vec![(Compute, vec![t(9, false)]), (Main, vec![t(9, true)])];
        assert_eq!(derive_waits(&war), vec![vec![], vec![0]]);
    }

    /// Across frames: the next frame's upload into the buffer the frame before read waits for that frame's
    /// reader on the main queue; its upload into the OTHER buffer (double-buffering) waits for nothing.
    #[test]
    fn cross_frame_hazards() {
        use QueueId::*;
        let previous = vec![(Main, vec![t(10, false), t(20, true)]), (Compute, vec![t(30, true)])];
        let same = [previous.clone(), vec![(Compute, vec![t(10, true)])]].concat();
        assert_eq!(derive_waits(&same)[2], vec![0]);
        let other = [previous.clone(), vec![(Compute, vec![t(11, true)])]].concat();
        assert_eq!(derive_waits(&other)[2], Vec::<usize>::new());
        // The next frame's async pass overwriting what the previous shading read waits for that shading.
        let war = [previous, vec![(Compute, vec![t(20, true)])]].concat();
        assert_eq!(derive_waits(&war)[2], vec![0]);
    }

    /// A schedule that breaks the overlap (main segment reading what the async one writes) gets the wait.
    #[test]
    fn a_pass_moved_across_queues_gets_its_wait() {
        use QueueId::*;
        let segs = vec![(Compute, vec![t(3, true)]), (Main, vec![t(3, false)])];
        assert_eq!(derive_waits(&segs), vec![vec![], vec![0]]);
    }
}
