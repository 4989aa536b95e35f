//! The constants of the simulation's equations for one scene and parameter set (kernel radius, mass,
//! relaxation, s_corr, time step, XSPH), the kernels they come from (poly6, spiky), and the uniform block the
//! shaders read (sim_common.glsl's `Sim`). Shared by the GPU stages and the CPU reference.

use glam::Vec3;

use super::params::Params;
use super::scene::SimScene;
use crate::compute::grid::GridShape;
use crate::shader_constants::MAX_COLLIDERS;

/// The simulation's uniform block (sim_common.glsl's `Sim`, std140).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SimUniforms {
    /// The neighbour grid.
    pub grid: GridShape,
    /// Container interior shrunk by the radius; time step.
    pub lo_dt: [f32; 4],
    /// Its upper corner; kernel radius h.
    pub hi_h: [f32; 4],
    /// Gravity; particle mass.
    pub gravity_mass: [f32; 4],
    /// ρ0, ε, s_corr k, 1/W(Δq).
    pub solver: [f32; 4],
    /// XSPH c, vorticity ε, particle radius, the weight Δt / (Δt + frame time) of a step in the low-passed
    /// change of velocity (the renderer's noise).
    pub visc: [f32; 4],
    /// h², poly6 coefficient, spiky gradient coefficient, particle volume m/ρ0.
    pub kern: [f32; 4],
    /// Particles, colliders, the neighbour lists' stride (particle capacity: list k of every particle is one
    /// contiguous run, so neighbouring threads read neighbouring words), s_corr exponent n.
    pub counts: [u32; 4],
    /// The mesh collider's lattice: first node, spacing.
    pub sdf_lo: [f32; 4],
    /// Its nodes per axis; w = 1 when there is one.
    pub sdf_dims: [u32; 4],
    /// The container's static friction μ_s (x).
    pub wall: [f32; 4],
    /// Two vec4 per collider.
    pub colliders: [[f32; 4]; 2 * MAX_COLLIDERS as usize],
    /// The emitter's nozzle ([`crate::sim::scene::Emitter::nozzle`]).
    pub nozzle: [[f32; 4]; 5],
}

/// The constants of the equations for one scene and parameter set (shared by the GPU and the CPU reference).
#[derive(Clone, Copy, Debug)]
pub struct Constants {
    /// Kernel radius h.
    pub h: f32,
    /// Particle mass.
    pub mass: f32,
    /// Particle volume m/ρ0.
    pub volume: f32,
    /// Relaxation ε (absolute).
    pub eps: f32,
    /// s_corr k (absolute, in λ's units).
    pub scorr_k: f32,
    /// 1 / W_poly6(Δq).
    pub inv_w_dq: f32,
    /// Time step.
    pub dt: f32,
    /// Steps per frame.
    pub substeps: u32,
    /// XSPH c: `Params::xsph`, or from the viscosity ν: Σ_j V (v_j − v_i) W_poly6 ≈ ⟨r²⟩/6 ∇²v with ⟨r²⟩ =
    /// 3h²/11 for poly6, so one step of c adds Δt ν ∇²v when c = 22 ν Δt / h². Clamped at `XSPH_MAX` (the
    /// explicit step's stability limit; a finer resolution than the viscosity resolves then gets less).
    pub xsph: f32,
    /// Kinematic viscosity ν (m²/s) the XSPH c follows from (`Params::viscosity`, else the scene's).
    pub nu: f32,
}

/// The largest XSPH c: Σ_j V W_poly6 ≈ 0.8 over a full neighbourhood, so c past ≈ 1.2 overshoots the mean.
pub const XSPH_MAX: f32 = 0.9;

/// W_poly6 for kernel radius h, of a squared distance.
pub fn poly6(r2: f32, h: f32) -> f32 {
    let h2 = h * h;
    if r2 >= h2 {
        return 0.0;
    }
    let d = h2 - r2;
    315.0 / (64.0 * std::f32::consts::PI * h.powi(9)) * d * d * d
}

/// ∇W_spiky at r = x_i − x_j.
pub fn spiky_grad(r: Vec3, h: f32) -> Vec3 {
    let l = r.length();
    if l >= h || l < 1e-9 * h {
        return Vec3::ZERO;
    }
    let a = h - l;
    (-45.0 / (std::f32::consts::PI * h.powi(6)) * a * a / l) * r
}

impl Constants {
    /// The constants for `scene` with `p`: h = 2 d; the mass makes the infinite lattice of spacing d exactly
    /// ρ0; ε and k are scaled by the lattice's Σ|∇C|².
    pub fn new(scene: &SimScene, p: &Params) -> Constants {
        let d = scene.spacing;
        let h = 2.0 * d;
        let mut w = 0.0;
        let mut grads = vec![];
        for k in -2i32..=2 {
            for j in -2i32..=2 {
                for i in -2i32..=2 {
                    let r = Vec3::new(i as f32, j as f32, k as f32) * d;
                    w += poly6(r.length_squared(), h);
                    if (i, j, k) != (0, 0, 0) {
                        grads.push(spiky_grad(r, h));
                    }
                }
            }
        }
        let mass = p.rest_density / w;
        let volume = mass / p.rest_density;
        let s0: f32 = grads.iter().map(|g| (volume * *g).length_squared()).sum();
        let substeps = if p.substeps > 0 {
            p.substeps
        } else {
            let top = scene
                .positions
                .iter()
                .map(|q| q[1])
                .chain(scene.emitter.map(|e| e.centre.y))
                .fold(scene.container.0.y, f32::max);
            let v0 = scene
                .velocities
                .iter()
                .map(|v| Vec3::from(*v).length())
                .chain(scene.emitter.map(|e| e.velocity.length()))
                .fold(0.0, f32::max);
            let speed = (2.0 * p.gravity[1].abs() * (top - scene.container.0.y)).sqrt() + v0;
            cfl_substeps(p, d, speed)
        };
        let nu = p.viscosity.unwrap_or(scene.viscosity);
        Constants {
            h,
            mass,
            volume,
            eps: p.relaxation * s0,
            scorr_k: p.scorr_k / s0,
            inv_w_dq: 1.0 / poly6((p.scorr_dq * h).powi(2), h),
            dt: 0.0,
            substeps: 0,
            xsph: 0.0,
            nu,
        }
        .with_substeps(substeps, p)
    }

    /// The same constants with `substeps` steps per frame: Δt = frame time / substeps, and the XSPH c that
    /// follows from Δt (`Params::xsph` as it is, else from ν).
    pub fn with_substeps(&self, substeps: u32, p: &Params) -> Constants {
        let dt = 1.0 / p.fps / substeps.max(1) as f32;
        let xsph = p.xsph.unwrap_or((22.0 * self.nu * dt / (self.h * self.h)).min(XSPH_MAX));
        Constants { dt, substeps: substeps.max(1), xsph, ..*self }
    }
}

impl Constants {
    /// A set-up whose step the solver cannot keep, refused: the step bound (CFL and `[sim] max_dt`) must hold
    /// within [`MAX_SUBSTEPS`] steps a frame (a tiny --fps or max_dt would otherwise take steps far longer than
    /// the bound without a word), and a viscosity the user set must be one the explicit XSPH step applies (it
    /// would be clamped at [`XSPH_MAX`] without a word: 250× the default moved the dam break's front by 0.4 %);
    /// a scene's own default is clamped (finer resolutions than it was set for get less viscosity).
    pub fn check_step(&self, params: &Params) -> crate::error::Result<()> {
        use crate::error::Error;
        if params.substeps == 0 && self.substeps >= MAX_SUBSTEPS {
            return Err(Error::Invalid(format!(
                "at {} frames/s a frame would need {} or more steps to keep the step within its bound ([sim] \
                 max_dt = {} s and the CFL bound): raise --fps (frames per simulated second) or [sim] max_dt",
                params.fps, MAX_SUBSTEPS, params.max_dt
            )));
        }
        let (asked, reach) = self.viscosity_reach();
        if let (Some(nu), None) = (params.viscosity, params.xsph) {
            if asked > XSPH_MAX * 1.0001 {
                return Err(Error::Invalid(format!(
                    "[sim] viscosity = {nu} m²/s needs an XSPH c of {asked:.2} per step at this resolution and step \
                     (Δt {:.2} ms, h {:.4} m), past the explicit step's stable {XSPH_MAX}: at most {reach:.3e} m²/s \
                     is applied here (more steps per frame, [sim] max_dt, raise it)",
                    self.dt * 1e3,
                    self.h
                )));
            }
        }
        Ok(())
    }

    /// The XSPH c the viscosity ν asks for at this step and resolution (22 ν Δt / h²), before the clamp at
    /// [`XSPH_MAX`]; with it, the largest ν the step applies (the one whose c is `XSPH_MAX`).
    pub fn viscosity_reach(&self) -> (f32, f32) {
        let asked = 22.0 * self.nu * self.dt / (self.h * self.h);
        (asked, XSPH_MAX * self.h * self.h / (22.0 * self.dt.max(1e-12)))
    }
}

/// The most steps a frame takes ([`cfl_substeps`]'s cap; `Simulation::new` refuses a set-up that needs more).
pub const MAX_SUBSTEPS: u32 = 1000;

/// Steps per frame under the CFL bound at `speed` (m/s) for particles `spacing` apart: ⌈frame time / min(cfl ×
/// spacing / speed, max_dt)⌉, in 1 ..= [`MAX_SUBSTEPS`].
pub fn cfl_substeps(p: &Params, spacing: f32, speed: f32) -> u32 {
    let dt_max = (p.cfl * spacing / speed.max(1e-3)).min(p.max_dt.max(1e-9));
    ((1.0 / p.fps / dt_max).ceil().min(1e9) as u32).clamp(1, MAX_SUBSTEPS)
}
