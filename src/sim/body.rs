//! The dynamic rigid sphere's buffers on the device (`scene::Body`; DFSPH, two-way coupled): its state — centre
//! and radius, velocity and mass, angular velocity, restitution and friction, the contact box — then each
//! particle's impulse on it in a step (sim_common.glsl's `Body` layout: the solves add, `sim_body` sums and
//! integrates, shaders_glsl/sim_body.comp). The host writes the initial state and reads the state back.
use std::sync::Arc;

use ash::vk;
use glam::Vec3;
use gpu_allocator::MemoryLocation;

use super::scene::{Collider, SimScene};
use crate::error::Result;
use crate::gpu::{Buffer, FrameCtx, Gpu};

/// vec4s of the body's state before the per-particle impulses (sim_common.glsl's BODY_HEAD).
const BODY_HEAD: usize = 6;

/// A dynamic body's state ([`crate::sim::Simulation::body_state`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyState {
    /// Centre (m).
    pub centre: Vec3,
    /// Velocity (m/s).
    pub velocity: Vec3,
    /// Angular velocity (rad/s; from its contacts with the container's faces).
    pub angular_velocity: Vec3,
}

/// The body's buffer (16 unused bytes without one) and its initial state, copied in when the scene starts again.
pub(super) struct BodyBuffers {
    pub(super) body: Buffer,
    init: Option<Buffer>,
}

/// PBF has no two-way coupling: there a dynamic body stands still, a sphere collider.
pub(super) fn for_pbf(scene: &mut SimScene) {
    if let Some(b) = scene.body.take() {
        scene.colliders.push(Collider::Sphere { centre: b.centre, radius: b.radius });
    }
}

impl BodyBuffers {
    /// The buffers for `scene`'s body (room for `cap` particles' impulses).
    pub(super) fn new(gpu: &Arc<Gpu>, scene: &SimScene, cap: u64, usage: vk::BufferUsageFlags) -> Result<Self> {
        let Some(b) = &scene.body else {
            return Ok(BodyBuffers {
                body: Buffer::new(gpu, "sim_body", 16, usage, MemoryLocation::GpuOnly)?,
                init: None,
            });
        };
        let (lo, hi) = b.contact_box.unwrap_or(scene.container);
        let head: [[f32; 4]; BODY_HEAD] = [
            b.centre.extend(b.radius).to_array(),
            b.velocity.extend(b.mass()).to_array(),
            [0.0; 4],
            [b.restitution, b.friction, 0.0, 0.0],
            lo.extend(0.0).to_array(),
            hi.extend(0.0).to_array(),
        ];
        let bytes = 16 * BODY_HEAD as u64;
        let mut init =
            Buffer::new(gpu, "sim_body_init", bytes, vk::BufferUsageFlags::TRANSFER_SRC, MemoryLocation::CpuToGpu)?;
        init.write(0, bytemuck::cast_slice(&head))?;
        let body = Buffer::new(gpu, "sim_body", bytes + 16 * cap, usage, MemoryLocation::GpuOnly)?;
        Ok(BodyBuffers { body, init: Some(init) })
    }

    /// Whether there is a body.
    pub(super) fn on(&self) -> bool {
        self.init.is_some()
    }

    /// Record the copy of the initial state (the scene starts again).
    pub(super) fn reset(&self, ctx: &mut FrameCtx) {
        if let Some(init) = &self.init {
            ctx.copy_buffer(init, &self.body, vk::BufferCopy { src_offset: 0, dst_offset: 0, size: init.size });
        }
    }

    /// The state after the frames recorded so far (waits for the device); None without a body.
    pub(super) fn state(&self, gpu: &Arc<Gpu>) -> Result<Option<BodyState>> {
        if !self.on() {
            return Ok(None);
        }
        let b = crate::gpu::transfer::read_buffer(gpu, &self.body, 48)?;
        let w: Vec<f32> = bytemuck::pod_collect_to_vec(&b);
        Ok(Some(BodyState {
            centre: Vec3::new(w[0], w[1], w[2]),
            velocity: Vec3::new(w[4], w[5], w[6]),
            angular_velocity: Vec3::new(w[8], w[9], w[10]),
        }))
    }
}
