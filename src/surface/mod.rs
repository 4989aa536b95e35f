//! The fluid's surface techniques, one module each: [`spheres`] (the splatted particle spheres — or
//! ellipsoids — smoothed in screen space afterwards), [`iso`] (the SPH colour field ray-cast per pixel, exact
//! or smoothed in 3D), [`mesh`] (the marching-cubes mesh of the same field, ray-cast through its BVH). Each owns
//! its resources and their staleness (grids, lattice, mesh, BVH, keyed to the particles' generation and its
//! settings), prepares them on the host before a frame, and records the passes that write the fluid depth;
//! the CPU references live beside each. What two techniques share lives apart, so that no technique imports
//! another: [`grid`] (the particles' grid, weights and kernels on the device) and the depth splat. The renderer
//! asks [`Surfaces::get`] for the one the settings name: a new surface is one module and one line there;
//! [`Surfaces::technique`] gives a technique by its type (a test's look at the iso surface's grid).

pub mod grid;
pub mod iso;
pub mod mesh;
pub mod spheres;
mod splat;

use std::sync::Arc;

use crate::error::Result;
use crate::gpu::executor::Executor;
use crate::gpu::{Buffer, FrameCtx, Gpu};
use crate::particles::ParticleSet;
use crate::passes::{FrameInfo, Passes};
use crate::settings::{Settings, Surface};
use crate::targets::Targets;

/// What a technique prepares with, on the host, before a frame is recorded.
pub struct Prepare<'a> {
    /// The device.
    pub gpu: &'a Arc<Gpu>,
    /// The frames in flight (waited for before a buffer they read is replaced).
    pub executor: &'a Executor,
    /// The particles.
    pub particles: &'a ParticleSet,
    /// The frame's settings.
    pub settings: &'a Settings,
    /// The fluid images' size (`TargetsDesc::fluid`): a technique's own frame resources follow it.
    pub fluid: ash::vk::Extent2D,
}

/// What a technique records with: the passes, the frame's images, uniforms and particles.
pub struct SurfaceFrame<'a> {
    /// Every pass.
    pub passes: &'a Passes,
    /// The frame's images.
    pub targets: &'a Targets,
    /// The frame uniform block.
    pub frame: &'a Buffer,
    /// The particle buffer and its count.
    pub particles: (&'a Buffer, u32),
    /// The frame's settings.
    pub settings: &'a Settings,
    /// Facts about this frame's camera.
    pub info: &'a FrameInfo,
}

/// Ellipsoid kernels on the device (Yu & Turk 2013), which `thickness` and `splat` draw instead of spheres.
#[derive(Clone, Copy)]
pub struct Kernels<'a> {
    /// The sorted kernel centres.
    pub points: &'a Buffer,
    /// How many.
    pub count: u32,
    /// The kernel matrices.
    pub aniso: &'a Buffer,
    /// How far a kernel reaches, in supports.
    pub stretch: f32,
    /// Every particle is a kernel (the grid was built on the GPU, no isolated particle left out): `thickness` may draw them.
    pub all_particles: bool,
}

/// One surface technique.
pub trait Technique: std::any::Any {
    /// Bring its resources up to date for the particles and settings (host work and allocations).
    fn prepare(&mut self, p: &Prepare) -> Result<()>;
    /// Record what the frame needs before `thickness` (grids, weights, kernels), in the part it belongs to;
    /// returns the ellipsoid kernels `thickness` and the depth draw, if any.
    fn record_kernels<'a>(
        &'a self,
        rec: &mut crate::gpu::recording::Recording,
        f: &SurfaceFrame<'a>,
    ) -> Option<Kernels<'a>>;
    /// Record the passes that write the fluid's depth into `targets.depth` (the fluid part).
    fn record_depth(&self, ctx: &mut FrameCtx, f: &SurfaceFrame, kernels: Option<Kernels>) -> Result<()>;
    /// The particles far from the fluid it left out, with the particle generation they were counted for (a
    /// caller warns once per generation: `scene::stray_warning`).
    fn strays(&self) -> Option<(u64, usize)> {
        None
    }
    /// (name, bytes) of its frame resources (`Renderer::state().memory()`).
    fn memory(&self) -> Vec<(&str, u64)> {
        vec![]
    }
    /// Whether the latest frame (finished) drew less than its resources should have held (read from the device):
    /// the next prepare grows them, and a one-frame render renders again (`Renderer::render`).
    fn outgrown(&self) -> bool {
        false
    }
}

/// The frame passes the techniques own, in frame order, where they run: after `splat`, before `filter`
/// (timestamp keys, JSON keys, `--timings` rows; `crate::frame::pass_names` puts them there). `anisotropy` runs
/// with `kernel = "anisotropic"`, `iso` with `surface = "iso"`, `mesh` (instead of `splat`) with
/// `surface = "mesh"`.
pub const PASS_NAMES: &[&str] = &[grid::anisotropy::NAME, iso::cast::NAME, mesh::cast::NAME];

/// Every surface technique, each owning its resources, in the order of `settings::Surface`.
pub struct Surfaces {
    all: Vec<Box<dyn Technique>>,
}

impl Surfaces {
    /// Every technique, with nothing built yet. THE LIST: a new surface is its module, one line here and its
    /// name in `settings::Surface` (same order).
    pub fn new() -> Surfaces {
        let all: Vec<Box<dyn Technique>> = vec![
            Box::new(spheres::Spheres::default()), // Surface::Spheres
            Box::new(iso::IsoSurface::default()),  // Surface::Iso
            Box::new(mesh::FluidMesh::default()),  // Surface::Mesh
        ];
        assert_eq!(all.len(), Surface::ALL.len(), "one technique per settings::Surface");
        Surfaces { all }
    }

    fn index(s: Surface) -> usize {
        Surface::ALL.iter().position(|x| *x == s).expect("every Surface is in ALL")
    }

    /// The technique the settings name.
    pub fn get_mut(&mut self, s: Surface) -> &mut dyn Technique {
        self.all[Self::index(s)].as_mut()
    }

    /// The technique the settings name.
    pub fn get(&self, s: Surface) -> &dyn Technique {
        self.all[Self::index(s)].as_ref()
    }

    /// The technique of type `T` (`iso::IsoSurface`, `mesh::FluidMesh`, `spheres::Spheres`), for what only it
    /// has: the iso surface's grid, the mesh's build statistics.
    pub fn technique<T: Technique>(&self) -> Option<&T> {
        self.all.iter().find_map(|t| (t.as_ref() as &dyn std::any::Any).downcast_ref::<T>())
    }

    /// (name, bytes) of every technique's frame resources.
    pub fn memory(&self) -> Vec<(&str, u64)> {
        self.all.iter().flat_map(|t| t.memory()).collect()
    }
}

impl Default for Surfaces {
    fn default() -> Self {
        Surfaces::new()
    }
}
