//! `meniscus mesh`: extract the SPH iso-surface of a particle file (or of every frame of a sequence) as a
//! triangle mesh — marching cubes over the colour field the `iso` pass ray-casts (`meniscus::extract`) — and
//! write it as PLY or OBJ. CPU only (rayon); `--threads` changes nothing but the time.

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::Args;

use meniscus::extract::{extract, ExtractParams};
use meniscus::iso::IsoGrid;
use meniscus::scene::{self, sequence::Prefetch, Particles};

use crate::args::{LoadArgs, SceneArgs};
use crate::job::{Job, Select};

/// `meniscus mesh`.
#[derive(Args, Clone, Debug)]
pub struct MeshArgs {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    load: LoadArgs,
    /// Output mesh, .ply (binary, with normals) or .obj; for a sequence {} in the name is the frame number
    /// (4 digits), else _NNNN is added before the extension.
    #[arg(short, long, default_value = "mesh.ply")]
    out: PathBuf,
    /// Marching-cubes edge length in particle radii (splashsurf's --cube-size).
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.5)]
    cube_size: f32,
    /// Kernel support in particle radii (splashsurf: 2 × smoothing length 2 = 4).
    #[arg(long, allow_negative_numbers = true, default_value_t = 4.0)]
    support: f32,
    /// Iso value of the normalised field (splashsurf: 0.6).
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.6)]
    threshold: f32,
    /// Evaluate the field at every cube corner within the kernel support (the reference) instead of following
    /// the surface in from the outside (which skips closed cavities inside the fluid).
    #[arg(long)]
    dense: bool,
    /// Worker threads (default: all cores); changes nothing but the time.
    #[arg(long)]
    threads: Option<usize>,
}

/// Run the extraction.
pub fn run(a: &MeshArgs) -> Result<()> {
    if !(a.cube_size.is_finite() && a.cube_size > 0.05 && a.cube_size <= 8.0) {
        bail!("--cube-size must be in (0.05, 8] particle radii");
    }
    if !(a.support.is_finite() && (1.0..=16.0).contains(&a.support)) {
        bail!("--support must be in [1, 16] particle radii");
    }
    if !(a.threshold > 0.0 && a.threshold < 1.0) {
        bail!("--threshold must be in (0, 1)");
    }
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(n) = a.threads {
        if n == 0 {
            bail!("--threads must be at least 1");
        }
        pool = pool.num_threads(n);
    }
    let pool = pool.build()?;
    let job = Job::open(&a.scene, &a.load, meniscus::settings::Settings::default(), Select::default())?;
    eprintln!("{}", job.summary(None));
    let r = job.settings.radius;
    let params = ExtractParams { cube: a.cube_size * r, threshold: a.threshold, dense: a.dense };
    let one = |p: &Particles, out: &PathBuf| -> Result<String> {
        let t0 = std::time::Instant::now();
        let m = pool.install(|| {
            let grid = IsoGrid::build(&p.positions, a.support * r);
            let inv = grid.inv_density();
            extract(&grid, &inv, &params)
        });
        let secs = t0.elapsed().as_secs_f64();
        meniscus::output::write_mesh(out, &m)?;
        Ok(format!(
            "{} particles → {} vertices, {} triangles in {:.2} s ({} threads) → {}",
            p.len(),
            m.vertices.len(),
            m.triangles.len(),
            secs,
            pool.current_num_threads(),
            out.display()
        ))
    };
    let Some(frames) = job.frames.clone() else {
        eprintln!("{}", one(&job.first, &a.out)?);
        return Ok(());
    };
    let out_name = |n: u64| -> PathBuf {
        let s = a.out.to_string_lossy();
        if s.contains("{}") {
            PathBuf::from(s.replace("{}", &format!("{n:04}")))
        } else {
            let stem = a.out.with_extension("");
            let ext = a.out.extension().map(|e| e.to_string_lossy().into_owned()).unwrap_or_else(|| "ply".into());
            PathBuf::from(format!("{}_{n:04}.{ext}", stem.display()))
        }
    };
    let bar = indicatif::ProgressBar::new(frames.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{bar:40} {pos}/{len} meshes  {per_sec:.2}  {msg}  [{elapsed} < {eta}]",
        )
        .expect("template"),
    );
    for (frame, loaded) in Prefetch::start(frames, job.load.clone(), 2) {
        let p: scene::Particles = loaded?;
        let line = one(&p, &out_name(frame.number))?;
        bar.set_message(line);
        bar.inc(1);
    }
    bar.finish();
    Ok(())
}
