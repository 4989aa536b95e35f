//! The particle set on the device, in one place: its two GPU buffers (a split frame uploads into the one the
//! frame before does not read), the count, the upload staged for the next frame's command buffer (or a GPU
//! producer such as the simulation), the host copy of the positions (the nearest depth, the CPU-built grids),
//! the isolated marks, and a generation that every change bumps — what the surface techniques key their caches to.
//!
//! Layout on the device ([`ParticleLayout`], the shaders' particle_layout.glsl): `count` vec4 positions (xyz, w:
//! radius and isolated mark) then `count` vec4 motions ([`Motion`]: the particle's id bits and how fast its velocity
//! changes), read by the `noise` pass, then (a GPU producer's) a header vec4, then the diffuse particles (spray,
//! foam, bubbles: two vec4 each, `crate::passes::diffuse::encode`), read by the `diffuse` pass. Every other pass
//! reads only the first `count` entries.

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::error::{Error, Result};
use crate::gpu::executor::Executor;
use crate::gpu::{Buffer, Gpu};
use crate::view::View;

use crate::motion::Motion;
use crate::shader_constants::ParticleLayout;
use crate::shader_constants::BYTES_PER_PARTICLE;

/// An upload staged for the next frame: `len` vec4s copied to vec4 offset `at` of the particle buffer — the fluid
/// part and the diffuse particles after it (`fluid`: a set uploaded from the host), or the diffuse particles alone
/// (a GPU producer's set). The vec4s stay in the set ([`ParticleSet::staged_parts`]): the frame writes them into
/// its staging buffer, with no copy of its own in between.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Staged {
    /// The first vec4 of the particle buffer written.
    pub at: usize,
    /// Vec4s written.
    pub len: usize,
    /// The fluid part leads (else the diffuse particles alone).
    pub fluid: bool,
}

/// What the host derives from a particle set's positions for the default surface's prepare — the fluid's box
/// and strays, and the smoothed field's lattice and marked bricks (`crate::surface::grid::analyse`) — computed
/// ahead, on whichever thread loaded the set (a sequence's prefetch), so a new frame's prepare does not walk its
/// particles on the render thread. Tied to the positions it was computed from ([`fingerprint`]) and to the
/// parameters it was computed for: the prepare uses what matches and computes the rest itself.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SetAnalysis {
    /// [`fingerprint`] of the positions.
    pub fingerprint: u64,
    /// The iso kernel's reach (world units) the box was computed for.
    pub reach: f32,
    /// `scene::fluid_bounds(positions, reach)`: the box and the strays left out.
    pub bounds: Option<(crate::scene::Bounds, usize)>,
    /// The smoothed field's lattice over the grid's box and the bricks the positions mark in it (`[iso]
    /// smoothing` > 0).
    pub volume: Option<(crate::field::volume::VolumeShape, u32)>,
}

/// A cheap identity of a set of positions: their count and the bits of up to 64 evenly strided ones (an analysis
/// of other positions is not used).
pub fn fingerprint(positions: &[[f32; 3]]) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    positions.len().hash(&mut h);
    let stride = positions.len().div_ceil(64).max(1);
    for p in positions.iter().step_by(stride).chain(positions.last()) {
        p.map(f32::to_bits).hash(&mut h);
    }
    h.finish()
}

/// The renderer's particles.
#[derive(Default)]
pub struct ParticleSet {
    buffers: [Option<Buffer>; 2],
    current: usize,
    count: u32,
    /// Set but not yet copied to the GPU: the next frame's command buffer records the copy (of these vec4s, to
    /// this vec4 offset in the buffer).
    staged: Option<Staged>,
    /// The fluid part of the last upload (positions, motions), kept to re-send with new diffuse particles.
    fluid: Vec<[f32; 4]>,
    /// The diffuse particles, encoded.
    diffuse: Vec<[f32; 4]>,
    /// Diffuse slots a GPU producer writes after the fluid (a simulation's pool), when the particles are external.
    gpu_diffuse: u32,
    /// The next frame's particles are written on the GPU by `Hooks::produce`.
    external: bool,
    /// The current particles were written on the GPU (the last set was `set_gpu`'s): the host holds only their box.
    gpu_written: bool,
    positions: Vec<[f32; 3]>,
    isolated: Option<Vec<bool>>,
    generation: u64,
    /// The current set's analysis, when its loader computed one ([`ParticleSet::set_analysis`]).
    analysis: Option<SetAnalysis>,
    /// The last [`ParticleSet::nearest_depth`].
    nearest: std::sync::Mutex<Option<NearestDepth>>,
}

/// A nearest particle depth and what it was computed for (particle set, view matrix and radius bits).
#[derive(Clone, Copy, PartialEq)]
struct NearestDepth {
    key: (u64, [u32; 16], u32),
    depth: f32,
}

impl ParticleSet {
    /// Set the particles: 16 bytes each (world xyz + w), w = the particle's radius from `radii`, else 0 (the
    /// frame's radius); negated for particles marked in `isolated` (kept out of the surface); then their `motion`
    /// (default: id = index, no change of velocity). `limit`: the device's storage buffer range.
    pub fn set(
        &mut self,
        limit: u64,
        positions: &[[f32; 3]],
        radii: Option<&[f32]>,
        isolated: Option<&[bool]>,
        motion: Option<&[Motion]>,
    ) -> Result<()> {
        let n = positions.len();
        let bytes = n as u64 * BYTES_PER_PARTICLE;
        if bytes > limit {
            return Err(Error::Limit(format!(
                "{n} particles need {bytes} bytes, more than this device's storage buffer limit of {limit} bytes ({} \
                 particles)",
                limit / BYTES_PER_PARTICLE
            )));
        }
        if let Some(m) = motion.filter(|m| m.len() != n) {
            return Err(Error::Invalid(format!("{} particle motions for {n} particles", m.len())));
        }
        // Into the last upload's vectors: a sequence sets a new frame every frame, and fresh allocations of a few MB
        // cost their page faults each time.
        let mut data = std::mem::take(&mut self.fluid);
        data.clear();
        data.extend(positions.iter().enumerate().map(|(i, p)| {
            let r = radii.map(|r| r[i]).unwrap_or(0.0);
            let isolated = isolated.is_some_and(|s| s[i]);
            // An isolated particle without its own radius: −1 means "frame radius" for the thickness pass.
            let w = if isolated {
                if r > 0.0 {
                    -r
                } else {
                    -f32::MIN_POSITIVE
                }
            } else {
                r
            };
            [p[0], p[1], p[2], w]
        }));
        match motion {
            Some(m) => data.extend(m.iter().map(Motion::encode)),
            None => data.extend((0..n as u32).map(|id| Motion { id, accel: 0.0 }.encode())),
        }
        self.fluid = data;
        self.gpu_diffuse = 0;
        self.external = false;
        self.gpu_written = false;
        self.count = n as u32;
        self.restage();
        self.positions.clear();
        self.positions.extend_from_slice(positions);
        // Kept only where a particle is marked (every frame asks whether any is).
        self.isolated = isolated.filter(|s| s.iter().any(|&x| x)).map(|s| s.to_vec());
        self.generation += 1;
        self.analysis = None;
        Ok(())
    }

    /// Attach the analysis its loader computed for the current set (ignored unless computed from these
    /// positions).
    pub fn set_analysis(&mut self, a: Option<&SetAnalysis>) {
        self.analysis = a.filter(|a| !self.external && a.fingerprint == fingerprint(&self.positions)).copied();
    }

    /// The current set's analysis, when its loader computed one.
    pub fn analysis(&self) -> Option<&SetAnalysis> {
        self.analysis.as_ref()
    }

    /// The next frame's `count` particles are written on the GPU by its `Hooks::produce` (positions and
    /// motions, see the module's layout); `bounds` contain them (the host copy becomes the box's corners).
    pub fn set_gpu(&mut self, limit: u64, count: u32, bounds: (glam::Vec3, glam::Vec3)) -> Result<()> {
        self.set_gpu_with_diffuse(limit, count, bounds, 0)
    }

    /// [`ParticleSet::set_gpu`] with `slots` diffuse particles the producer writes after the fluid's positions
    /// and motions (two vec4 each; an empty slot has fade 0).
    pub fn set_gpu_with_diffuse(
        &mut self,
        limit: u64,
        count: u32,
        bounds: (glam::Vec3, glam::Vec3),
        slots: u32,
    ) -> Result<()> {
        if (count as u64 + slots as u64) * BYTES_PER_PARTICLE > limit {
            return Err(Error::Limit(format!("{count} particles exceed this device's storage buffer limit")));
        }
        let (lo, hi) = bounds;
        self.positions = (0..8)
            .map(|k| {
                [
                    if k & 1 == 0 { lo.x } else { hi.x },
                    if k & 2 == 0 { lo.y } else { hi.y },
                    if k & 4 == 0 { lo.z } else { hi.z },
                ]
            })
            .collect();
        self.fluid.clear();
        self.external = true;
        self.gpu_written = true;
        self.count = count;
        self.gpu_diffuse = slots;
        if slots > 0 {
            self.diffuse.clear();
        }
        self.restage();
        self.isolated = None;
        self.generation += 1;
        self.analysis = None;
        Ok(())
    }

    /// Set the diffuse particles (encoded, two vec4 each), drawn after the fluid particles; the fluid's
    /// generation is unchanged (the surfaces do not depend on them).
    pub fn set_diffuse(&mut self, limit: u64, encoded: Vec<[[f32; 4]; 2]>) -> Result<()> {
        let bytes = (self.count as u64 + encoded.len() as u64) * BYTES_PER_PARTICLE;
        if bytes > limit {
            return Err(Error::Limit(format!(
                "{} particles and {} diffuse particles need {bytes} bytes, more than this device's storage buffer limit of \
                 {limit} bytes",
                self.count,
                encoded.len()
            )));
        }
        self.diffuse = encoded.into_iter().flatten().collect();
        self.gpu_diffuse = 0;
        self.restage();
        Ok(())
    }

    /// Stage what the next frame copies: the fluid (positions, motions) and the uploaded diffuse particles
    /// after it; for a GPU producer, which writes the fluid part, only the diffuse particles, at their place.
    fn restage(&mut self) {
        self.staged = if self.external {
            let at = self.layout().diffuse() as usize;
            (!self.diffuse.is_empty()).then_some(Staged { at, len: self.diffuse.len(), fluid: false })
        } else {
            Some(Staged { at: 0, len: self.fluid.len() + self.diffuse.len(), fluid: true })
        };
    }

    /// The vec4s of a staged upload, in order: the fluid part (when it leads) and the diffuse particles.
    pub fn staged_parts(&self, s: &Staged) -> [&[[f32; 4]]; 2] {
        [if s.fluid { self.fluid.as_slice() } else { &[] }, self.diffuse.as_slice()]
    }

    /// The diffuse particles are written on the GPU after a header (their count and the `diffuse` pass's
    /// indirect dispatch: `Simulation::set_diffuse`), not uploaded.
    pub fn diffuse_on_gpu(&self) -> bool {
        self.gpu_diffuse > 0
    }

    /// Diffuse particles on the device (at most, for a GPU producer's).
    pub fn diffuse_count(&self) -> u32 {
        if self.gpu_diffuse > 0 {
            self.gpu_diffuse
        } else {
            (self.diffuse.len() / 2) as u32
        }
    }

    /// The buffer's layout: a GPU producer's diffuse particles follow a header vec4.
    pub fn layout(&self) -> ParticleLayout {
        ParticleLayout { count: self.count, header: self.gpu_diffuse > 0, diffuse: self.diffuse_count() }
    }

    /// Particles on the device.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// The host copy of the positions (the box's corners for GPU-written particles).
    pub fn positions(&self) -> &[[f32; 3]] {
        &self.positions
    }

    /// Whether any particle is marked isolated.
    pub fn has_isolated(&self) -> bool {
        self.isolated.is_some()
    }

    /// The positions of the particles that make the surface (isolated ones left out).
    pub fn surface_positions(&self) -> Vec<[f32; 3]> {
        match &self.isolated {
            Some(isolated) => self.positions.iter().zip(isolated).filter(|(_, s)| !**s).map(|(p, _)| *p).collect(),
            None => self.positions.clone(),
        }
    }

    /// Bumped by every change of the particles.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// The particles are written on the GPU (a simulation), not uploaded.
    pub fn is_external(&self) -> bool {
        self.external
    }

    /// The current particles were written on the GPU (a simulation's, `set_gpu`): the host holds only the box
    /// around them, in the frames after the one that produced them too.
    pub fn gpu_written(&self) -> bool {
        self.gpu_written
    }

    /// Linear depth of the nearest particle surface in front of the camera (at least the near plane).
    /// Every frame asks; it is computed once per particle set, camera and radius (a still scene's frames and a
    /// sequence's frame after the first ask again), over the particles in parallel (the minimum is exact in any
    /// order).
    pub fn nearest_depth(&self, view: &View, radius: f32) -> f32 {
        use rayon::prelude::*;
        let m = view.camera.view();
        let key = (self.generation, m.to_cols_array().map(f32::to_bits), radius.to_bits());
        let mut last = self.nearest.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(n) = last.filter(|n| n.key == key) {
            return n.depth.max(view.camera.near);
        }
        let d = self
            .positions
            .par_iter()
            .with_min_len(4096)
            .map(|p| -(m.transform_point3(glam::Vec3::from(*p)).z) - radius)
            .filter(|d| *d > -radius)
            .reduce(|| f32::INFINITY, f32::min);
        *last = Some(NearestDepth { key, depth: d });
        d.max(view.camera.near)
    }

    /// Before recording a frame: pick the buffer it reads — a split frame uploads into the other one (the frame
    /// before may still read this one), a one-queue frame into the same (queue order keeps it after the
    /// readers) — and grow it when too small, after every frame that may still read it.
    pub fn prepare(&mut self, gpu: &std::sync::Arc<Gpu>, executor: &Executor, split: bool) -> Result<()> {
        let whole = self.layout().bytes();
        if self.staged.is_some() || self.external {
            let target = if split { 1 - self.current } else { self.current };
            let size = whole.max(16);
            if self.buffers[target].as_ref().is_none_or(|b| b.size < size) {
                executor.wait_idle()?;
                self.buffers[target] = Some(Buffer::new(
                    gpu,
                    if target == 0 { "particles" } else { "particles (second)" },
                    size,
                    vk::BufferUsageFlags::STORAGE_BUFFER
                        | vk::BufferUsageFlags::TRANSFER_DST
                        | vk::BufferUsageFlags::INDIRECT_BUFFER,
                    MemoryLocation::GpuOnly,
                )?);
            }
            self.current = target;
        }
        if self.buffers[self.current].is_none() {
            return Err(Error::Invalid("no particles uploaded".into()));
        }
        Ok(())
    }

    /// The buffer this frame reads (after [`ParticleSet::prepare`]).
    pub fn buffer(&self) -> &Buffer {
        self.buffers[self.current].as_ref().expect("prepared")
    }

    /// Take what this frame records before its passes: the staged upload (vec4s and their vec4 offset in the
    /// buffer), and whether a producer writes the buffer.
    pub fn take_pending(&mut self) -> (Option<Staged>, bool) {
        (self.staged.take(), std::mem::take(&mut self.external))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What a frame copies: a host set's fluid part (positions, then motions) and its diffuse particles after it,
    /// from offset 0; a GPU producer's set only the diffuse particles, at their place after the header. A new
    /// frame's set reuses the vectors and stages the new values only.
    #[test]
    fn the_staged_upload_is_the_layout() {
        let mut set = ParticleSet::default();
        let limit = u64::MAX;
        let staged = |set: &ParticleSet| {
            let s = set.staged.expect("staged");
            let parts = set.staged_parts(&s);
            (s, parts.concat())
        };
        set.set(limit, &[[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]], None, None, None).unwrap();
        let (s, data) = staged(&set);
        assert_eq!(s, Staged { at: 0, len: 4, fluid: true });
        assert_eq!(data[..2], [[1.0, 2.0, 3.0, 0.0], [4.0, 5.0, 6.0, 0.0]]);
        assert_eq!(data[2..], [Motion { id: 0, accel: 0.0 }.encode(), Motion { id: 1, accel: 0.0 }.encode()]);
        set.set_diffuse(limit, vec![[[7.0; 4], [8.0; 4]]]).unwrap();
        let (s, data) = staged(&set);
        assert_eq!(s, Staged { at: 0, len: 6, fluid: true });
        assert_eq!(data[4..], [[7.0; 4], [8.0; 4]]);
        set.set(limit, &[[9.0, 9.0, 9.0]], None, None, None).unwrap();
        let (s, data) = staged(&set);
        assert_eq!((s.len, data.len(), data[0]), (4, 4, [9.0, 9.0, 9.0, 0.0]));
        assert_eq!(set.positions(), &[[9.0, 9.0, 9.0]]);
        // A producer's set keeps the uploaded diffuse particles, staged at their place after its fluid part.
        set.set_gpu_with_diffuse(limit, 5, (glam::Vec3::ZERO, glam::Vec3::ONE), 0).unwrap();
        let (s, data) = staged(&set);
        assert_eq!(s, Staged { at: 10, len: 2, fluid: false });
        assert_eq!(data, [[7.0; 4], [8.0; 4]]);
        set.set_diffuse(limit, vec![[[1.0; 4], [2.0; 4]]]).unwrap();
        let (s, data) = staged(&set);
        assert_eq!(s, Staged { at: set.layout().diffuse() as usize, len: 2, fluid: false });
        assert_eq!(data, [[1.0; 4], [2.0; 4]]);
    }
}
