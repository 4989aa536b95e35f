//! The particles' motion between the frames of a sequence: what the `noise` pass needs to raise its amplitude
//! where the flow is violent (NVIDIA patent US 8,947,430, eq. 17: particles whose velocity changes faster than a
//! threshold). A [`MotionTracker`] walks the frames in time order and gives each particle its
//! [`Motion`]: its id (the file's, else its index) and |Δv| / Δt, from the file's velocities where it has them,
//! else from the positions of the frames before (by id, or by index when the count is unchanged). A single
//! frame has no change of velocity: [`still`].

use std::collections::HashMap;

use glam::Vec3;

use crate::scene::Particles;

/// What the `noise` pass knows of a particle's motion: the second half of the particle buffer, one vec4 each.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Motion {
    /// The particle's identity (its id in the file, else its index): seeds its noise, so the pattern stays with
    /// the particle from frame to frame.
    pub id: u32,
    /// How fast its velocity changes, |Δv| / Δt (world units / s²); 0 when unknown (a single frame).
    pub accel: f32,
}

impl Motion {
    /// The GPU layout: (id bits, accel, 0, 0).
    pub fn encode(&self) -> [f32; 4] {
        [f32::from_bits(self.id), self.accel, 0.0, 0.0]
    }
}

/// Frames per second assumed when a sequence does not say (SPlisHSPlasH's default export rate).
pub const DEFAULT_FPS: f32 = 25.0;

/// The particles' ids as the noise seeds them (the file's id, truncated to 32 bits, else the index), with no
/// change of velocity.
pub fn still(p: &Particles) -> Vec<Motion> {
    (0..p.len()).map(|i| Motion { id: id_of(p, i), accel: 0.0 }).collect()
}

fn id_of(p: &Particles, i: usize) -> u32 {
    p.ids.as_ref().map_or(i as u32, |ids| ids[i] as u32)
}

/// What the tracker keeps of the frame before.
struct Previous {
    positions: Vec<[f32; 3]>,
    /// Velocities of that frame (the file's, or estimated from the frame before it).
    velocities: Option<Vec<[f32; 3]>>,
    /// id → index, when the frame had ids.
    index: Option<HashMap<i64, usize>>,
}

/// Walks a sequence in time order; see the module.
pub struct MotionTracker {
    fps: f32,
    prev: Option<Previous>,
}

impl MotionTracker {
    /// A tracker for frames `1 / fps` seconds apart (`fps` ≤ 0 or not finite: [`DEFAULT_FPS`]).
    pub fn new(fps: f32) -> MotionTracker {
        MotionTracker { fps: if fps.is_finite() && fps > 0.0 { fps } else { DEFAULT_FPS }, prev: None }
    }

    /// The velocities of the frame last given to [`MotionTracker::next`]: the file's, else estimated from the
    /// positions of the frame before (zero where a particle cannot be followed); none for a first frame
    /// without velocities.
    pub fn velocities(&self) -> Option<&[[f32; 3]]> {
        self.prev.as_ref()?.velocities.as_deref()
    }

    /// The motion of the next frame's particles (and remember them for the frame after).
    pub fn next(&mut self, p: &Particles) -> Vec<Motion> {
        let n = p.len();
        let prev = self.prev.take();
        // Where each particle was in the frame before: by id when both frames have ids, else by index when the
        // count is unchanged.
        let matched: Vec<Option<usize>> = match (&prev, &p.ids) {
            (Some(Previous { index: Some(index), .. }), Some(ids)) => {
                ids.iter().map(|id| index.get(id).copied()).collect()
            }
            (Some(q), _) if q.positions.len() == n => (0..n).map(Some).collect(),
            _ => vec![None; n],
        };
        let fps = self.fps;
        let velocities: Option<Vec<[f32; 3]>> = p.velocities.clone().or_else(|| {
            let q = prev.as_ref()?;
            let moved = |i: usize, j: usize| (Vec3::from(p.positions[i]) - Vec3::from(q.positions[j])) * fps;
            Some((0..n).map(|i| matched[i].map_or(Vec3::ZERO, |j| moved(i, j)).to_array()).collect())
        });
        let motion = (0..n)
            .map(|i| {
                let before = prev.as_ref().and_then(|q| Some(q.velocities.as_ref()?[matched[i]?]));
                let accel = match (before, &velocities) {
                    (Some(b), Some(v)) => (Vec3::from(v[i]) - Vec3::from(b)).length() * fps,
                    _ => 0.0,
                };
                Motion { id: id_of(p, i), accel }
            })
            .collect();
        let index = p.ids.as_ref().map(|ids| ids.iter().enumerate().map(|(i, &id)| (id, i)).collect());
        self.prev = Some(Previous { positions: p.positions.clone(), velocities, index });
        motion
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(positions: Vec<[f32; 3]>, ids: Option<Vec<i64>>, velocities: Option<Vec<[f32; 3]>>) -> Particles {
        Particles { positions, ids, velocities, ..Default::default() }
    }

    /// Positions only: the first frame and the second (one velocity) have no change; the third has it, by id
    /// even when the file reorders its particles.
    #[test]
    fn change_of_velocity_from_positions_by_id() {
        let mut t = MotionTracker::new(10.0);
        // Particle 7 at rest; particle 9 falls with constant acceleration 2 (x = t²), sampled at 10 fps.
        let x = |k: f32| (k / 10.0) * (k / 10.0);
        let m0 = t.next(&frame(vec![[0.0; 3], [0.0, x(0.0), 0.0]], Some(vec![7, 9]), None));
        assert_eq!(m0, vec![Motion { id: 7, accel: 0.0 }, Motion { id: 9, accel: 0.0 }]);
        let m1 = t.next(&frame(vec![[0.0, x(1.0), 0.0], [0.0; 3]], Some(vec![9, 7]), None));
        assert_eq!(m1.iter().map(|m| m.accel).collect::<Vec<_>>(), vec![0.0, 0.0]);
        let m2 = t.next(&frame(vec![[0.0; 3], [0.0, x(2.0), 0.0]], Some(vec![7, 9]), None));
        assert_eq!(m2[0], Motion { id: 7, accel: 0.0 });
        assert_eq!(m2[1].id, 9);
        assert!((m2[1].accel - 2.0).abs() < 1e-3, "{}", m2[1].accel);
    }

    /// The file's velocities give the change from the second frame on; without ids particles match by index.
    #[test]
    fn change_of_velocity_from_the_files_velocities() {
        let mut t = MotionTracker::new(25.0);
        let p = |vy: f32| frame(vec![[0.0; 3], [1.0; 3]], None, Some(vec![[0.0; 3], [0.0, vy, 0.0]]));
        assert!(t.next(&p(0.0)).iter().all(|m| m.accel == 0.0));
        let m = t.next(&p(-1.0));
        assert_eq!(m[0], Motion { id: 0, accel: 0.0 });
        assert_eq!(m[1].id, 1);
        assert!((m[1].accel - 25.0).abs() < 1e-4);
        // A frame with a different count and no ids cannot be matched: no change.
        let q = frame(vec![[0.0; 3]], None, Some(vec![[5.0; 3]]));
        assert_eq!(t.next(&q), vec![Motion { id: 0, accel: 0.0 }]);
    }

    #[test]
    fn a_single_frame_is_still() {
        let p = frame(vec![[0.0; 3]; 3], Some(vec![4, 5, 6]), None);
        assert_eq!(still(&p).iter().map(|m| (m.id, m.accel)).collect::<Vec<_>>(), vec![(4, 0.0), (5, 0.0), (6, 0.0)]);
    }
}
