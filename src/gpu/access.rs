//! How a pass uses a resource, and the barrier that use needs.
//!
//! ONE table ([`Access::info`]) maps an access kind to (pipeline stage, access mask, image layout), after
//! wgpu-hal's `conv.rs`. Each image and buffer remembers its [`AccessState`]; [`AccessState::transition`]
//! derives the synchronization2 barrier a new use needs from it. The frame code never writes a barrier by hand.
//! Pure functions: unit-tested without a GPU.

use ash::vk;

/// The ways a pass can touch a resource.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Access {
    /// Read as a storage image / storage buffer / uniform in a compute shader.
    ComputeRead,
    /// Sampled through a sampler, or a uniform texel buffer fetched, in a compute shader.
    ComputeSampled,
    /// Written (or read and written, atomics) as storage in a compute shader.
    ComputeWrite,
    /// Colour attachment of a graphics pass (written).
    ColorAttachment,
    /// Depth attachment, tested and written.
    DepthAttachment,
    /// Vertex/fragment shaders read it as storage (graphics splat variants).
    GraphicsRead,
    /// Source of a copy.
    TransferSrc,
    /// Destination of a copy or clear.
    TransferDst,
    /// Read by the host after the queue finished.
    HostRead,
    /// Written by the host before submission.
    HostWrite,
    /// Presented to a swapchain.
    Present,
    /// Read as the arguments of an indirect dispatch.
    IndirectRead,
}

/// The Vulkan view of an [`Access`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AccessInfo {
    /// Pipeline stages of the access.
    pub stage: vk::PipelineStageFlags2,
    /// Access mask.
    pub access: vk::AccessFlags2,
    /// Image layout the access needs.
    pub layout: vk::ImageLayout,
    /// Whether the access writes.
    pub writes: bool,
}

impl Access {
    /// THE table: stage, access mask, layout and whether it writes.
    pub const fn info(self) -> AccessInfo {
        use vk::{AccessFlags2 as A, ImageLayout as L, PipelineStageFlags2 as S};
        let (stage, access, layout, writes) = match self {
            Access::ComputeRead => {
                (S::COMPUTE_SHADER, A::SHADER_STORAGE_READ.as_raw() | A::UNIFORM_READ.as_raw(), L::GENERAL, false)
            }
            Access::ComputeSampled => {
                (S::COMPUTE_SHADER, A::SHADER_SAMPLED_READ.as_raw(), L::SHADER_READ_ONLY_OPTIMAL, false)
            }
            Access::ComputeWrite => (
                S::COMPUTE_SHADER,
                A::SHADER_STORAGE_READ.as_raw() | A::SHADER_STORAGE_WRITE.as_raw(),
                L::GENERAL,
                true,
            ),
            Access::ColorAttachment => (
                S::COLOR_ATTACHMENT_OUTPUT,
                A::COLOR_ATTACHMENT_READ.as_raw() | A::COLOR_ATTACHMENT_WRITE.as_raw(),
                L::COLOR_ATTACHMENT_OPTIMAL,
                true,
            ),
            Access::DepthAttachment => (
                S::from_raw(S::EARLY_FRAGMENT_TESTS.as_raw() | S::LATE_FRAGMENT_TESTS.as_raw()),
                A::DEPTH_STENCIL_ATTACHMENT_READ.as_raw() | A::DEPTH_STENCIL_ATTACHMENT_WRITE.as_raw(),
                L::DEPTH_ATTACHMENT_OPTIMAL,
                true,
            ),
            Access::GraphicsRead => (
                S::from_raw(S::VERTEX_SHADER.as_raw() | S::FRAGMENT_SHADER.as_raw()),
                A::SHADER_STORAGE_READ.as_raw() | A::UNIFORM_READ.as_raw() | A::SHADER_SAMPLED_READ.as_raw(),
                L::GENERAL,
                false,
            ),
            Access::TransferSrc => (S::ALL_TRANSFER, A::TRANSFER_READ.as_raw(), L::TRANSFER_SRC_OPTIMAL, false),
            Access::TransferDst => (S::ALL_TRANSFER, A::TRANSFER_WRITE.as_raw(), L::TRANSFER_DST_OPTIMAL, true),
            Access::HostRead => (S::HOST, A::HOST_READ.as_raw(), L::GENERAL, false),
            Access::HostWrite => (S::HOST, A::HOST_WRITE.as_raw(), L::GENERAL, true),
            Access::Present => (S::NONE, 0, L::PRESENT_SRC_KHR, false),
            Access::IndirectRead => (S::DRAW_INDIRECT, A::INDIRECT_COMMAND_READ.as_raw(), L::GENERAL, false),
        };
        AccessInfo { stage, access: A::from_raw(access), layout, writes }
    }
}

/// What a resource remembers about its past: the last write and who has read it since.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AccessState {
    /// Current image layout (UNDEFINED for buffers).
    pub layout: vk::ImageLayout,
    /// Stage and access of the last write not yet followed by a full barrier to every later reader.
    pub write_stage: vk::PipelineStageFlags2,
    /// Stages and access of the last write not yet made visible (none when the resource was only read).
    pub write_access: vk::AccessFlags2,
    /// Stages and accesses that read since the last write (and already waited for it).
    pub read_stage: vk::PipelineStageFlags2,
    /// Accesses that read since the last write (a later write must wait for them).
    pub read_access: vk::AccessFlags2,
}

impl Default for AccessState {
    fn default() -> Self {
        AccessState {
            layout: vk::ImageLayout::UNDEFINED,
            write_stage: vk::PipelineStageFlags2::NONE,
            write_access: vk::AccessFlags2::NONE,
            read_stage: vk::PipelineStageFlags2::NONE,
            read_access: vk::AccessFlags2::NONE,
        }
    }
}

/// One derived dependency (image or buffer; `old_layout == new_layout` for buffers).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Dependency {
    /// Stages to wait for.
    pub src_stage: vk::PipelineStageFlags2,
    /// Accesses to make available.
    pub src_access: vk::AccessFlags2,
    /// Stages that wait.
    pub dst_stage: vk::PipelineStageFlags2,
    /// Accesses to make visible.
    pub dst_access: vk::AccessFlags2,
    /// Layout before.
    pub old_layout: vk::ImageLayout,
    /// Layout after.
    pub new_layout: vk::ImageLayout,
}

impl AccessState {
    /// The barrier needed before `next`, and the state after it. `discard`: the pass overwrites the whole
    /// resource, so the old contents (and layout) need not be kept.
    pub fn transition(self, next: Access, discard: bool) -> (Option<Dependency>, AccessState) {
        let info = next.info();
        let old_layout = if discard { vk::ImageLayout::UNDEFINED } else { self.layout };
        let layout_change = self.layout != info.layout;
        if info.writes {
            // Write after write: wait for the write. Write after read: an execution dependency on the readers
            // is enough, their accesses need no flush.
            let src_stage = self.write_stage | self.read_stage;
            let dep = Dependency {
                src_stage,
                src_access: self.write_access,
                dst_stage: info.stage,
                dst_access: info.access,
                old_layout,
                new_layout: info.layout,
            };
            let needed = layout_change || !src_stage.is_empty();
            let state = AccessState {
                layout: info.layout,
                write_stage: info.stage,
                write_access: info.access & Self::write_bits(),
                read_stage: vk::PipelineStageFlags2::NONE,
                read_access: vk::AccessFlags2::NONE,
            };
            (needed.then_some(dep), state)
        } else if layout_change {
            // A transition is itself a write: every later reader in another stage must wait for it.
            let dep = Dependency {
                src_stage: self.write_stage | self.read_stage,
                src_access: self.write_access,
                dst_stage: info.stage,
                dst_access: info.access,
                old_layout,
                new_layout: info.layout,
            };
            let state = AccessState {
                layout: info.layout,
                write_stage: info.stage,
                write_access: vk::AccessFlags2::NONE,
                read_stage: info.stage,
                read_access: info.access,
            };
            (Some(dep), state)
        } else {
            let covered = self.read_stage.contains(info.stage) && self.read_access.contains(info.access);
            let state = AccessState {
                read_stage: self.read_stage | info.stage,
                read_access: self.read_access | info.access,
                ..self
            };
            if self.write_stage.is_empty() || covered {
                (None, state)
            } else {
                let dep = Dependency {
                    src_stage: self.write_stage,
                    src_access: self.write_access,
                    dst_stage: info.stage,
                    dst_access: info.access,
                    old_layout: self.layout,
                    new_layout: info.layout,
                };
                (Some(dep), state)
            }
        }
    }

    /// [`AccessState::transition`] for a buffer, which has no layout. (Before commit 49486fa buffers went through
    /// the image rule with the layout forgotten each time, so every read looked like a layout transition and
    /// replaced the reads before it: a buffer read by a shader and then as indirect arguments lost the shader
    /// read, and the next write waited for the indirect read alone — the write-after-read hazard sync
    /// validation reported on the `iso` queue header.)
    pub fn buffer_transition(self, next: Access) -> (Option<Dependency>, AccessState) {
        let (dep, state) = AccessState { layout: next.info().layout, ..self }.transition(next, false);
        (dep, AccessState { layout: vk::ImageLayout::UNDEFINED, ..state })
    }

    fn write_bits() -> vk::AccessFlags2 {
        vk::AccessFlags2::SHADER_STORAGE_WRITE
            | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE
            | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE
            | vk::AccessFlags2::TRANSFER_WRITE
            | vk::AccessFlags2::HOST_WRITE
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A buffer read in two stages, then written: the write waits for both reads (and a read after a read
    /// needs no barrier of its own beyond the write it follows).
    #[test]
    fn buffer_reads_accumulate_until_the_next_write() {
        let (_, st) = AccessState::default().buffer_transition(Access::ComputeWrite);
        let (dep, st) = st.buffer_transition(Access::ComputeRead);
        assert_eq!(dep.unwrap().src_stage, vk::PipelineStageFlags2::COMPUTE_SHADER);
        let (dep, st) = st.buffer_transition(Access::IndirectRead);
        assert_eq!(dep.unwrap().dst_stage, vk::PipelineStageFlags2::DRAW_INDIRECT);
        let (dep, _) = st.buffer_transition(Access::ComputeWrite);
        let src = dep.unwrap().src_stage;
        assert!(
            src.contains(vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::DRAW_INDIRECT),
            "{src:?}"
        );
    }

    #[test]
    fn first_write_transitions_from_undefined() {
        let (dep, st) = AccessState::default().transition(Access::ComputeWrite, true);
        let dep = dep.unwrap();
        assert_eq!(dep.old_layout, vk::ImageLayout::UNDEFINED);
        assert_eq!(dep.new_layout, vk::ImageLayout::GENERAL);
        assert_eq!(st.write_stage, vk::PipelineStageFlags2::COMPUTE_SHADER);
    }

    #[test]
    fn read_after_write_waits_once() {
        let (_, st) = AccessState::default().transition(Access::ComputeWrite, true);
        let (dep, st) = st.transition(Access::ComputeRead, false);
        let dep = dep.expect("RAW needs a barrier");
        assert_eq!(dep.src_access, vk::AccessFlags2::SHADER_STORAGE_WRITE);
        // A second reader of the same kind is already covered.
        let (dep2, _) = st.transition(Access::ComputeRead, false);
        assert!(dep2.is_none());
    }

    #[test]
    fn write_after_read_is_execution_only() {
        let (_, st) = AccessState::default().transition(Access::ComputeWrite, true);
        let (_, st) = st.transition(Access::ComputeRead, false);
        let (dep, _) = st.transition(Access::ComputeWrite, false);
        let dep = dep.unwrap();
        assert!(dep.src_stage.contains(vk::PipelineStageFlags2::COMPUTE_SHADER));
    }

    #[test]
    fn sampled_read_changes_layout() {
        let (_, st) = AccessState::default().transition(Access::ComputeWrite, true);
        let (dep, st) = st.transition(Access::ComputeSampled, false);
        let dep = dep.unwrap();
        assert_eq!(dep.old_layout, vk::ImageLayout::GENERAL);
        assert_eq!(dep.new_layout, vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL);
        let (dep, _) = st.transition(Access::TransferSrc, false);
        assert_eq!(dep.unwrap().new_layout, vk::ImageLayout::TRANSFER_SRC_OPTIMAL);
    }

    #[test]
    fn read_only_resource_never_barriers() {
        let st = AccessState { layout: vk::ImageLayout::GENERAL, ..Default::default() };
        let (dep, st) = st.transition(Access::ComputeRead, false);
        assert!(dep.is_none());
        let (dep, _) = st.transition(Access::ComputeRead, false);
        assert!(dep.is_none());
    }
}
