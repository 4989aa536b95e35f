//! The emitter's side of a frame: the particles it adds before the frame's steps, and — with recycling
//! (SPlisHSPlasH's `emitterReuseParticles`, [`crate::sim::scene::Emitter::reuse`]) — the particles that left the
//! recycling box taken back for them first.
//!
//! SPlisHSPlasH (`EmitterSystem::reuseParticles`, `Emitter::emitParticles`) checks every step: the particles
//! outside the box, in index order, carry the emitter's next particles before the room for new ones
//! (`maxEmitterParticles`) is used; the ones left waiting are slowed by 0.95 (so they do not shrink the CFL step).
//! Here the emitter adds a frame's layers at the frame's start, so the check is made then: the state is read back
//! (the frame before is waited for: a recycling scene has one frame in flight), the particles outside the box in
//! the order of the last step carry the frame's layers, the others outside are slowed by 0.95 per step of the
//! frame before, and the state goes back up with the new particles after it. A particle that leaves the box
//! waits for the next frame's check where SPlisHSPlasH's waits for its next step.

use glam::Vec3;

use super::{Pending, Simulation};
use crate::error::Result;

/// An emitted particle: position, velocity.
type Emitted = ([f32; 3], [f32; 3]);

/// What recycling leaves: the layers for new particles, and the whole state to upload when a particle was
/// outside the box (`None`: the state stays).
struct Recycled {
    rest: Vec<Emitted>,
    state: Option<Vec<[f32; 8]>>,
}

/// Velocity kept per step by a particle waiting outside the recycling box (SPlisHSPlasH's factor).
pub const WAITING_SLOWDOWN: f32 = 0.95;

impl Simulation {
    /// Add the emitter's particles for the coming frame to the pending upload (recycling first, when the scene
    /// recycles and the state is on the device).
    pub(super) fn emit(&mut self) -> Result<()> {
        let (t0, t1) = (self.time, self.time + 1.0 / self.params.fps as f64);
        let room = self.capacity().saturating_sub(self.count()) as usize;
        let reuse = self.scene.emitter.and_then(|e| e.reuse);
        let (mut layers, rows) = match reuse {
            // Recycled particles carry any number of the frame's layers; new ones fill the room.
            Some(bounds) if self.pending.is_none() && self.frames > 0 && self.n > 0 => {
                let r = self.recycle(bounds, self.scene.emit(t0, t1, usize::MAX))?;
                (r.rest, r.state)
            }
            _ => (self.scene.emit(t0, t1, room), None),
        };
        layers.truncate(room);
        if layers.is_empty() && rows.is_none() {
            return Ok(());
        }
        let at = self.count();
        let pending = self.pending.get_or_insert_with(|| match rows {
            Some(rows) => Pending { at: 0, fresh: at, rows },
            None => Pending { at, fresh: at, rows: vec![] },
        });
        for (p, v) in layers {
            pending.rows.push([p[0], p[1], p[2], f32::from_bits(self.next_id), v[0], v[1], v[2], 0.0]);
            self.next_id += 1;
        }
        Ok(())
    }

    /// The particles outside `bounds` (lo, hi) carry `layers` (positions, velocities) in the order of the last
    /// step, the others outside are slowed.
    fn recycle(&mut self, (lo, hi): (Vec3, Vec3), layers: Vec<Emitted>) -> Result<Recycled> {
        let n = self.n as usize;
        let mut state: Vec<[f32; 8]> = {
            let held = self.read_back_state(false)?;
            let bytes = held.as_ref().expect("read back").read()?;
            bytemuck::cast_slice(&bytes[..32 * n]).to_vec()
        };
        let slow = WAITING_SLOWDOWN.powi(self.constants.substeps as i32);
        let (mut used, mut outside) = (0, 0);
        for row in &mut state {
            let x = Vec3::new(row[0], row[1], row[2]);
            if x.cmpge(lo).all() && x.cmple(hi).all() {
                continue;
            }
            outside += 1;
            match layers.get(used) {
                Some((p, v)) => {
                    row[..3].copy_from_slice(p);
                    row[4..7].copy_from_slice(v);
                    used += 1;
                }
                None => row[4..7].iter_mut().for_each(|c| *c *= slow),
            }
        }
        self.reused += used as u64;
        let rest = layers[used..].to_vec();
        Ok(Recycled { rest, state: (outside > 0).then_some(state) })
    }

    /// Particles the emitter has recycled since the start (SPlisHSPlasH's `numReusedParticles`).
    pub fn reused(&self) -> u64 {
        self.reused
    }
}
