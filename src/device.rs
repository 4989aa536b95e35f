//! The device as the applications see it. The CLI, the demo, the benchmark and the Python package use the GPU
//! through these items only (`tests/layout.rs` holds them to it); each is defined in the device layer
//! (`crate::gpu`), which is the library's own: its programs, executor, schedule and access tracking are public
//! only so that the library's integration tests can drive single passes, and it is hidden from the
//! documentation, so every item here has one documented path.
//!
//! - **A device**: [`Gpu`] (`Gpu::new(&GpuOptions)`, shared as `Arc<Gpu>` by renderers and simulations),
//!   [`GpuOptions`], what it is ([`DeviceInfo`]), what it holds ([`MemoryReport`]) and how its async compute
//!   queue relates to the main one ([`AsyncQueue`]).
//! - **What a hook records with** (the demo's swapchain blit and overlay, a simulation's copy into the
//!   particle buffer, Python's read-back): [`FrameCtx`], [`Buffer`], [`Image`], their accesses ([`Access`],
//!   [`Use`]: the barriers are derived from them) and [`record_upload`].
//! - **A frame's handles**: [`Submitted`] (a frame handed to the GPU, to be finished by the renderer),
//!   [`Binary`] (the semaphores a presentation waits for and signals) and [`QueueId`] (the benchmark's
//!   per-queue times: its one door to the timestamps, which are otherwise `crate::timing`'s).

pub use crate::gpu::executor::{Binary, Submitted};
pub use crate::gpu::queues::AsyncQueue;
pub use crate::gpu::schedule::QueueId;
pub use crate::gpu::transfer::record_upload;
pub use crate::gpu::{Access, Buffer, DeviceInfo, FrameCtx, Gpu, GpuOptions, Image, MemoryReport, Use};
