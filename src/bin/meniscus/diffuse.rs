//! `meniscus diffuse`: the diffuse particles of a sequence — spray, foam and air bubbles ([`meniscus::diffuse`],
//! Ihmsen et al. 2012 with Bender et al. 2019's automatic limits) — generated in time order and written per frame
//! with their type, velocity, lifetime and id (SPlisHSPlasH's FoamGenerator's files and type numbers, so Blender
//! and Houdini read them). [`Walk`] is the generation `render --diffuse` shares.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;

use meniscus::diffuse::{
    self,
    generator::{Generator, StepStats},
    potentials::Fluid,
    Kind, Particle,
};
use meniscus::motion::MotionTracker;
use meniscus::output::{FileKind, PARTICLE_KINDS};
use meniscus::scene::Particles;
use meniscus::settings::Settings;

use crate::args::{check_out, LoadArgs, Numbered, SceneArgs};
use crate::job::{Job, Select};

/// `meniscus diffuse`.
#[derive(Args, Clone, Debug)]
#[command(after_help = "Example: meniscus diffuse 'ParticleData_Fluid_{}.bgeo' --export 'foam/f_{}.bgeo' && \
meniscus render 'ParticleData_Fluid_{}.bgeo' --diffuse 'foam/f_{}.bgeo' --out frames/")]
pub struct DiffuseArgs {
    /// A sequence: a pattern with {} for the frame number, a folder, a glob or a .pvd. Its frames are walked
    /// in time order from the first (velocities from the files' `velocity`, else from the particles' motion).
    pub input: String,
    /// Output pattern: {} is the frame number (4 digits); .bgeo or .vtk; a folder gets frame_NNNN.bgeo inside.
    /// Each file holds the diffuse particles of its frame: position, velocity, lifetime (s left), age (s),
    /// source (the spawning fluid particle's id), type (0 foam, 1 spray, 2 bubbles) and id. Never written over an
    /// input or into the input sequence; written whole or not at all.
    #[arg(long, value_name = "PATTERN")]
    pub export: PathBuf,
    /// One file per type, as FoamGenerator's --splittypes: _foam, _spray and _bubbles before the extension.
    #[arg(long)]
    pub split_types: bool,
    /// Replace exported files that exist already (without it, an export whose files exist is refused: they
    /// belong to another run).
    #[arg(long)]
    pub overwrite: bool,
    /// Write only these frames, FIRST..LAST[:STEP] (the generation still starts at the sequence's first frame).
    #[arg(long = "frames", value_name = "RANGE")]
    pub frames_range: Option<String>,
    /// Particle radius (default: a scene.json beside the files, or estimated from the particles).
    #[arg(long, value_parser = crate::args::finite::<f32>, allow_negative_numbers = true)]
    pub radius: Option<f32>,
    /// Ignore a SPlisHSPlasH scene.json beside the files (its radius and frame rate).
    #[arg(long)]
    pub no_scene_json: bool,
    /// TOML settings; its `[diffuse]` section sets the generation (foam_scale, lifetime, automatic and the
    /// limits, buoyancy, drag, …; README: Settings).
    #[arg(long)]
    pub settings: Option<PathBuf>,
    #[command(flatten)]
    pub load: LoadArgs,
}

/// The diffuse particles of a job's sequence, generated frame by frame in time order (from its first frame,
/// whatever range is rendered or written), so frame k holds the same particles however a run is split.
pub struct Walk {
    whole: Vec<meniscus::scene::sequence::Frame>,
    load: meniscus::scene::LoadOptions,
    params: diffuse::params::Params,
    radius: f32,
    fps: f32,
    gen: Generator,
    tracker: MotionTracker,
    /// Index in `job.whole` of the next frame to feed.
    next: usize,
    /// What the last step did.
    pub last: StepStats,
}

impl Walk {
    /// A walk over `job`'s sequence with its `[diffuse]` settings; automatic limits are calibrated first.
    pub fn new(job: &Job) -> Result<Walk> {
        if job.whole.is_empty() {
            bail!("diffuse particles are generated from a sequence (a pattern with {{}}, a folder or a glob)");
        }
        let p = &job.settings.diffuse;
        let limits = if p.automatic { calibrate(job)? } else { p.limits() };
        eprintln!(
            "diffuse limits ({}): trapped air {:.4} … {:.4}, wave crest {:.4} … {:.4}, kinetic energy {:.3e} … {:.3e}",
            if p.automatic { "automatic, Bender 2019" } else { "from the settings" },
            limits.trapped_air[0],
            limits.trapped_air[1],
            limits.wave_crest[0],
            limits.wave_crest[1],
            limits.kinetic[0],
            limits.kinetic[1]
        );
        Ok(Walk {
            whole: job.whole.clone(),
            load: job.load.clone(),
            params: p.clone(),
            radius: job.settings.radius,
            fps: job.frame_rate(),
            gen: Generator::new(p, limits, 1.0 / job.frame_rate()),
            tracker: job.motion(),
            next: 0,
            last: StepStats::default(),
        })
    }

    /// Walk up to and including the frame numbered `number` (loading the frames before it that were not fed;
    /// `loaded`: that frame's particles when the caller has them).
    pub fn advance(&mut self, number: u64, loaded: Option<&Particles>) -> Result<&[Particle]> {
        let whole = &self.whole;
        let at = whole.partition_point(|f| f.number < number);
        if whole.get(at).is_none_or(|f| f.number != number) {
            bail!("frame {number} is not in the sequence");
        }
        if at < self.next {
            // Backwards: start again from the first frame.
            self.gen = Generator::new(&self.params, self.gen.limits(), 1.0 / self.fps);
            self.tracker = MotionTracker::new(self.fps);
            self.next = 0;
        }
        while self.next <= at {
            let f = &whole[self.next];
            let owned;
            let p = match loaded {
                Some(p) if self.next == at => p,
                _ => {
                    owned = meniscus::scene::load_with(&f.path, &self.load)?;
                    &owned
                }
            };
            drop(self.tracker.next(p));
            let fluid = Fluid::new(&p.positions, self.tracker.velocities(), p.ids.as_deref(), self.radius);
            self.last = self.gen.step(&fluid, f.number);
            self.next += 1;
        }
        Ok(&self.gen.particles)
    }

    /// Living particles of each kind (foam, spray, bubbles).
    pub fn counts(&self) -> [usize; 3] {
        self.gen.counts()
    }
}

/// Bender 2019's automatic limits from up to 17 frames spread evenly over the sequence (the first and the last
/// included); a frame without velocities gets them from the frame before it.
fn calibrate(job: &Job) -> Result<diffuse::params::Limits> {
    let n = job.whole.len();
    let picks: Vec<usize> = if n <= 17 { (0..n).collect() } else { (0..17).map(|k| k * (n - 1) / 16).collect() };
    let bar = crate::args::progress(picks.len() as u64, "frames");
    bar.set_message("calibrating the diffuse limits");
    let (mut maxima, mut floor) = (vec![], 0f32);
    for &k in &picks {
        let f = &job.whole[k];
        let p = meniscus::scene::load_with(&f.path, &job.load)?;
        let mut t = job.motion();
        if p.velocities.is_none() && k > 0 {
            drop(t.next(&meniscus::scene::load_with(&job.whole[k - 1].path, &job.load)?));
        }
        drop(t.next(&p));
        let fluid = Fluid::new(&p.positions, t.velocities(), p.ids.as_deref(), job.settings.radius);
        maxima.push(diffuse::potentials::frame_maxima(&fluid, job.settings.diffuse.min_neighbours));
        floor = fluid.kinetic_floor();
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(diffuse::potentials::calibrate(&maxima, floor))
}

/// `path` with `_suffix` before its particle-file extension (.bgeo, .bgeo.gz, .vtk).
fn with_suffix(path: &Path, suffix: &str) -> PathBuf {
    let s = path.to_string_lossy();
    for ext in [".bgeo.gz", ".bgeo", ".vtk"] {
        if let Some(stem) = s.strip_suffix(ext) {
            return PathBuf::from(format!("{stem}_{suffix}{ext}"));
        }
    }
    PathBuf::from(format!("{s}_{suffix}"))
}

/// `meniscus diffuse`.
pub fn run(a: &DiffuseArgs) -> Result<()> {
    if !meniscus::scene::sequence::is_sequence(&a.input) {
        bail!("{}: `diffuse` walks a sequence (a pattern with {{}}, a folder or a glob)", a.input);
    }
    let mut settings = Settings::default();
    if let Some(f) = &a.settings {
        settings = crate::args::settings_file(&settings, f)?;
    }
    let scene = SceneArgs {
        input: a.input.clone(),
        radius: a.radius,
        particles: None,
        camera: None,
        background_obj: None,
        no_scene_json: a.no_scene_json,
    };
    let select = Select {
        range: a.frames_range.as_deref().map(meniscus::scene::sequence::FrameRange::parse).transpose()?,
        shard: None,
    };
    let job = Job::open(&scene, &a.load, settings, select)?;
    let frames = job.frames.clone().expect("a sequence");
    let names = Numbered::new(&a.export, "bgeo");
    let kind = FileKind::by_extension(&names.path(0), &PARTICLE_KINDS).context("--export")?;
    let outputs = |n: u64| -> Vec<(Option<Kind>, PathBuf)> {
        let p = names.path(n);
        if a.split_types {
            Kind::ALL.into_iter().map(|k| (Some(k), with_suffix(&p, k.name()))).collect()
        } else {
            vec![(None, p)]
        }
    };
    let all: Vec<PathBuf> = frames.iter().flat_map(|f| outputs(f.number)).map(|(_, p)| p).collect();
    for p in &all {
        // Refused there too: a name the input sequence would read as one of its frames.
        check_out("--export", p, kind)?;
    }
    crate::args::refuse_existing("--export", &all, a.overwrite)?;
    for p in &all {
        if let Some(dir) = p.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).with_context(|| format!("--export: cannot create {}", dir.display()))?;
        }
    }
    eprintln!("{}", job.summary(None));
    let mut walk = Walk::new(&job)?;
    let bar = crate::args::progress(frames.len() as u64, "frames");
    let t0 = std::time::Instant::now();
    println!("frame\tfoam\tspray\tbubbles\tspawned\tdied");
    let mut peak = 0;
    for f in &frames {
        let ps = walk.advance(f.number, None)?.to_vec();
        let c = walk.counts();
        peak = peak.max(ps.len());
        bar.suspend(|| {
            println!("{}\t{}\t{}\t{}\t{}\t{}", f.number, c[0], c[1], c[2], walk.last.spawned, walk.last.died)
        });
        if walk.last.dropped > 0 {
            bar.suspend(|| {
                eprintln!(
                    "warning: frame {}: {} spawns dropped: {} diffuse particles live ([diffuse] max_particles)",
                    f.number,
                    walk.last.dropped,
                    ps.len()
                )
            });
        }
        for (k, path) in outputs(f.number) {
            let part: Vec<Particle> = ps.iter().filter(|p| k.is_none_or(|k| p.kind == k)).copied().collect();
            meniscus::scene::write_particles(&path, &diffuse::io::to_particles(&part))?;
        }
        bar.set_message(format!("{} diffuse particles", ps.len()));
        bar.inc(1);
    }
    bar.finish_and_clear();
    eprintln!(
        "{} frames of diffuse particles written to {} in {:.1} s (at most {peak} at once)",
        frames.len(),
        names.path(frames[0].number).parent().map(|p| p.display().to_string()).unwrap_or(".".into()),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
