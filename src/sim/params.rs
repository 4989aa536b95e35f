//! The `[sim]` settings section: the solver (PBF or DFSPH), its time step, iterations and error bounds, the
//! fluid's constants (rest density, viscosity, vorticity, wall friction, gravity), with their defaults and
//! ranges (`crate::section::Section`).

use super::constants::XSPH_MAX;
use crate::error::{Error, Result};

/// Solver settings: the `[sim]` section of a settings file.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Frames per simulated second (the export rate; each frame is `substeps` steps).
    pub fps: f32,
    /// Steps per frame; 0 = from the CFL bound (`cfl` × spacing / free-fall speed of the scene's height).
    pub substeps: u32,
    /// CFL number of the automatic step.
    pub cfl: f32,
    /// The automatic step re-chosen every frame from the largest speed of the frame before (`cfl` × spacing /
    /// speed, at most `max_dt`; SPlisHSPlasH's `cflMethod` 1) instead of once from the free-fall speed of the
    /// scene's height. With `substeps` > 0 the step stays fixed.
    pub adaptive_step: bool,
    /// Longest automatic step (s); SPlisHSPlasH's dam-break scene caps its step at 5 ms too.
    pub max_dt: f32,
    /// Solver iterations per step.
    pub iterations: u32,
    /// Relaxation ε as a fraction of Σ|∇C|² of the initial lattice (constraint-force mixing).
    pub relaxation: f32,
    /// Tensile-instability strength k, in units of 1/Σ|∇C|² of the lattice (so it reads like a constraint value).
    pub scorr_k: f32,
    /// Tensile-instability exponent n, a whole number 1..=15 (the shader multiplies: a `pow` made sim_solve 23 %
    /// slower on lavapipe, which runs both sides of a branch; docs/simulation.md, commit 434fdd1).
    pub scorr_n: u32,
    /// Tensile-instability reference distance Δq as a fraction of h.
    pub scorr_dq: f32,
    /// Kinematic viscosity ν (m²/s), applied as XSPH with c = 22 ν Δt / h² (see [`Constants::xsph`]); absent:
    /// the scene's ([`SimScene::viscosity`]: 0.02 for `dambreak` and `pool` — twice the shared SPlisHSPlasH
    /// set-up's "Standard viscosity" 0.01, because 4 PBF iterations leave a slow stirring in water at rest that
    /// DFSPH's converged solve does not (the resting pool after 2 s, 5,000–12,000 particles: 0.032–0.051 m/s at
    /// 0.01, 0.022–0.034 at 0.02; the 59k dam-break front then trails SPlisHSPlasH's by ≤ 1.9 % of the tank instead of ≤ 0.9 %:
    /// docs/simulation.md, commit c680c5d) — and 0.001 for the splash scenes `drop` and `waterfall`, whose crown and spray
    /// 0.01 smears into a smooth ring).
    pub viscosity: Option<f32>,
    /// XSPH c used as it is instead of the one derived from `viscosity` (c per step, so its effect depends on Δt
    /// and h).
    pub xsph: Option<f32>,
    /// Vorticity confinement ε (m/s); 0 (the default) switches it off, and `sim_vorticity` is not recorded.
    pub vorticity: f32,
    /// Static friction coefficient μ_s of the container's faces (0: free slip). See sim_velocity.comp.
    pub wall_friction: f32,
    /// Gravity (m/s²).
    pub gravity: [f32; 3],
    /// Rest density (kg/m³).
    pub rest_density: f32,
    /// The pressure solver: `pbf` (Position Based Fluids, `iterations` Jacobi iterations; the live default) or
    /// `dfsph` (Divergence-free SPH: the divergence-free and constant-density solves iterated to their error
    /// bounds, [`dfsph`]).
    pub solver: Solver,
    /// DFSPH: the constant-density solve's bound on the average density error, percent of ρ0 (SPlisHSPlasH's
    /// `maxError`).
    pub max_density_error: f32,
    /// DFSPH: the divergence-free solve's bound on the average density change over a step, percent of ρ0
    /// (SPlisHSPlasH's `maxErrorV`).
    pub max_divergence_error: f32,
    /// DFSPH: most corrections per solve (recorded up to it, or by `adaptive_corrections`; the solves stop on
    /// the GPU once converged, and a recorded correction left over costs an empty indirect dispatch). 100,
    /// SPlisHSPlasH's default: the 59k dam break's
    /// collapse at 5 ms steps needs up to 52 to keep the 0.05 % bound in its floor impact (at 20 a quarter of
    /// its steps stopped at the limit, at up to 0.155 %). A resting pool converged from its first step stays at
    /// rest since its lattice keeps `scene::WALL_GAP` from the walls (docs/simulation.md). A SPlisHSPlasH scene
    /// file brings its own (`DFSPH.maxIterations`).
    pub max_solver_iterations: u32,
    /// DFSPH: record each solve's corrections by what recent steps performed — the most either solve needed in
    /// the last `ADAPTIVE_WINDOW` frames plus `ADAPTIVE_SPARE`, all `max_solver_iterations` again the frame after a
    /// step stopped at that count above its bound — instead of all `max_solver_iterations` (the default, `false`).
    /// A recorded correction after convergence is an empty indirect dispatch and its barriers, which still cost
    /// (lavapipe: the 3,000-particle dam break's step 32.6 → 11.9 ms, the same water bit for bit; the H100: ~9 µs
    /// each). Off by default: where the need jumps within a frame (the 59k collapse's floor impact) the count
    /// recorded from the frames before cuts steps short (6 of 48, at up to 0.24 % against the 0.05 % bound;
    /// docs/simulation.md): for a run that wants DFSPH's frame time more than its bound in every step.
    pub adaptive_corrections: bool,
}

/// Corrections recorded beyond the most a solve performed in the recent frames ([`Params::adaptive_corrections`]).
pub const ADAPTIVE_SPARE: u32 = 8;

/// Frames whose most corrections per solve the adaptive count keeps ([`Params::adaptive_corrections`]).
pub const ADAPTIVE_WINDOW: usize = 32;

crate::named::named_enum! {
    /// The pressure solver of a [`Simulation`] (`[sim] solver`, `sim --solver`, Python's `solver=`): one name
    /// everywhere, from this declaration.
    #[derive(Default)]
    pub enum Solver {
        /// Position Based Fluids (Macklin & Müller 2013): a fixed iteration count.
        #[default]
        Pbf = "pbf",
        /// Divergence-free SPH (Bender & Koschier 2015): two velocity solves to error bounds.
        Dfsph = "dfsph",
    }
}

impl Default for Params {
    fn default() -> Self {
        Params {
            fps: 25.0,
            substeps: 0,
            cfl: 1.0,
            max_dt: 0.005,
            adaptive_step: false,
            iterations: 4,
            relaxation: 0.01,
            scorr_k: 0.02,
            scorr_n: 4,
            scorr_dq: 0.2,
            viscosity: None,
            xsph: None,
            vorticity: 0.0,
            wall_friction: 1.0,
            gravity: [0.0, -9.81, 0.0],
            rest_density: 1000.0,
            solver: Solver::Pbf,
            max_density_error: 0.05,
            max_divergence_error: 0.1,
            max_solver_iterations: 100,
            adaptive_corrections: false,
        }
    }
}

impl Params {
    /// The solver and its settings in words, for the log lines of `sim`, `sim validate` and `bench --sim`.
    pub fn solver_summary(&self) -> String {
        match self.solver {
            Solver::Pbf => format!("PBF, {} iterations", self.iterations),
            Solver::Dfsph => format!(
                "DFSPH to {} % density error and {} % divergence per step, at most {} corrections per solve",
                self.max_density_error, self.max_divergence_error, self.max_solver_iterations
            ),
        }
    }

    /// Whether each frame's step is chosen from the frame before's largest speed: `adaptive_step`, unless
    /// `substeps` fixes the step.
    pub fn adapts_step(&self) -> bool {
        self.adaptive_step && self.substeps == 0
    }

    /// Reject values the solver cannot run with (the section's check as an error).
    pub fn validate(&self) -> Result<()> {
        crate::section::Section::check(self).map_err(|(_, reason)| Error::Invalid(reason))
    }
}

impl crate::section::Section for Params {
    fn name(&self) -> &'static str {
        "sim"
    }

    fn check(&self) -> crate::section::Checked {
        let k = crate::section::Keys("sim");
        k.above("fps", self.fps, 0.0, 10_000.0)?;
        k.count("substeps", self.substeps, 0, 1000)?;
        k.above("cfl", self.cfl, 0.0, 10.0)?;
        k.above("max_dt", self.max_dt, 0.0, 1.0)?;
        k.count("iterations", self.iterations, 1, 100)?;
        k.above("relaxation", self.relaxation, 0.0, 1e6)?;
        k.within("scorr_k", self.scorr_k, 0.0, 1.0)?;
        k.count("scorr_n", self.scorr_n, 1, 15)?;
        k.within("scorr_dq", self.scorr_dq, 0.0, 1.0)?;
        if let Some(v) = self.viscosity {
            k.within("viscosity", v, 0.0, 1e3)?;
        }
        if let Some(c) = self.xsph {
            // Larger c overshoots the neighbours' mean velocity.
            k.within("xsph", c, 0.0, XSPH_MAX)?;
        }
        k.within("vorticity", self.vorticity, 0.0, 100.0)?;
        k.within("wall_friction", self.wall_friction, 0.0, 10.0)?;
        k.each("gravity", &self.gravity, -1e4, 1e4)?;
        k.above("rest_density", self.rest_density, 0.0, 1e6)?;
        k.above("max_density_error", self.max_density_error, 0.0, 10.0)?;
        k.above("max_divergence_error", self.max_divergence_error, 0.0, 100.0)?;
        k.count("max_solver_iterations", self.max_solver_iterations, 2, 200)
    }
}
