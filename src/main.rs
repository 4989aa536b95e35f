//! `meniscus` — the command line: `render` (headless to PNG), `info` (what a particle file holds),
//! `scenes` (the built-in scenes).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand};

use meniscus::frame::{Environment, View};
use meniscus::gpu::{Gpu, GpuOptions};
use meniscus::renderer::{read_f32, Renderer};
use meniscus::scene::{self, procedural, Camera, Particles};
use meniscus::settings::{Filter, Settings};

#[derive(Parser)]
#[command(name = "meniscus", version, about = "Screen-space fluid rendering of SPH particles on Vulkan")]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Render one frame headless to a PNG.
    Render(RenderArgs),
    /// Describe a particle file: format, count, attributes, bounds, spacing and suggested radius.
    Info {
        /// A .bgeo (gzip or plain) or legacy .vtk file.
        file: PathBuf,
    },
    /// List the built-in procedural scenes.
    Scenes,
}

#[derive(Args, Clone)]
struct RenderArgs {
    /// A built-in scene (block, wave, drop) or a particle file (.bgeo, .vtk).
    #[arg(default_value = "wave")]
    input: String,
    /// Output PNG (written atomically: no half-written file on failure).
    #[arg(short, long, default_value = "frame.png")]
    out: PathBuf,
    #[arg(long, default_value_t = 960)]
    width: u32,
    #[arg(long, default_value_t = 540)]
    height: u32,
    /// Particle radius in world units (default: from the scene, or half the median particle spacing).
    #[arg(long, allow_negative_numbers = true)]
    radius: Option<f32>,
    /// Particle count of a built-in scene (default: the scene's own).
    #[arg(long)]
    particles: Option<usize>,
    /// Camera as EYE:TARGET[:FOVY_DEG], e.g. 0,2.5,6:0,0.3,0:45 (default: fitted to the particles).
    #[arg(long)]
    camera: Option<String>,
    /// Depth smoothing filter.
    #[arg(long, value_enum)]
    filter: Option<Filter>,
    /// Settings preset: default, fast.
    #[arg(long, default_value = "default")]
    preset: String,
    /// TOML file of settings applied over the preset's (see README).
    #[arg(long)]
    settings: Option<PathBuf>,
    /// Print a per-pass GPU time table (median over the timed frames, after warm-up).
    #[arg(long)]
    timings: bool,
    /// With --timings: frames rendered first and not timed (lavapipe compiles pipelines at first use).
    #[arg(long, default_value_t = 2)]
    warmup: u32,
    /// With --timings: frames timed; the table shows per-pass medians.
    #[arg(long, default_value_t = 5)]
    frames: u32,
    /// Write buffers next to the PNG as OUT.NAME.npy (float32): depth, smoothed, thickness; normals as .npy (H,W,3).
    #[arg(long, value_delimiter = ',')]
    dump: Vec<String>,
    /// Enable the Vulkan validation layer with synchronization validation (also MENISCUS_VALIDATION=1).
    #[arg(long)]
    validation: bool,
    /// Use the first device whose name contains this (also MENISCUS_DEVICE).
    #[arg(long)]
    device: Option<String>,
}

fn main() {
    let cli = Cli::parse();
    let r = match cli.cmd {
        Cmd::Render(a) => render(&a),
        Cmd::Info { file } => info(&file),
        Cmd::Scenes => {
            for (name, n, what) in procedural::SCENES {
                println!("{name:8} {n:>9} particles  {what}");
            }
            Ok(())
        }
    };
    if let Err(e) = r {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

/// Particles and the radius they come with (if the source knows it).
fn load_input(input: &str, count: Option<usize>) -> Result<(Particles, Option<f32>, String)> {
    if let Some((name, n, _)) = procedural::SCENES.iter().find(|s| s.0 == input) {
        let g = procedural::generate(name, count.unwrap_or(*n))?;
        return Ok((g.particles, Some(g.radius), format!("scene {name}")));
    }
    let path = Path::new(input);
    if !path.exists() {
        let known: Vec<&str> = procedural::SCENES.iter().map(|s| s.0).collect();
        bail!("{input}: no such file, and not a built-in scene ({})", known.join(", "));
    }
    if count.is_some() {
        bail!("--particles applies to built-in scenes only");
    }
    Ok((scene::load(path)?, None, input.to_string()))
}

fn render(a: &RenderArgs) -> Result<()> {
    let (particles, scene_radius, label) = load_input(&a.input, a.particles)?;
    let mut s = match &a.settings {
        Some(f) => Settings::from_toml(f)?,
        None => Settings::preset(&a.preset)?,
    };
    if let Some(f) = a.filter {
        s.filter = f;
    }
    s.radius = match a.radius.or(scene_radius) {
        Some(r) => r,
        None => {
            let r = scene::estimate_radius(&particles.positions)
                .context("cannot estimate the particle radius (too few distinct particles); pass --radius")?;
            eprintln!("radius {r:.5} estimated from the particle spacing (pass --radius to override)");
            r
        }
    };
    s.validate()?;
    let bounds = scene::percentile_bounds(&particles.positions, 0.01).context("no finite particle positions")?;
    let camera = match &a.camera {
        Some(c) => Camera::parse(c)?,
        None => Camera::fit(&bounds, a.width as f32 / a.height.max(1) as f32),
    };
    let view = View { camera, width: a.width, height: a.height, env: Environment::around(&bounds, s.radius, &s) };
    for d in &a.dump {
        if !["depth", "smoothed", "thickness", "normals", "final"].contains(&d.as_str()) {
            bail!("--dump {d:?}: expected some of depth, smoothed, thickness, normals, final");
        }
    }

    let gpu = Gpu::new(&GpuOptions { validation: a.validation, device_filter: a.device.clone() })?;
    let mut r = Renderer::new(&gpu)?;
    r.set_particles(&particles.positions, None)?;
    let mut times = r.render(&view, &s)?;
    if a.timings {
        let mut runs = vec![];
        for k in 0..a.warmup + a.frames.max(1) {
            let t = r.render(&view, &s)?;
            if k >= a.warmup {
                runs.push(t);
            }
        }
        times = meniscus::gpu::timer::median_times(&runs);
    }
    let img = r.read_final()?;
    meniscus::output::write_png(&a.out, &img)?;
    eprintln!(
        "{label}: {} particles, radius {}, {}×{} on {} → {}",
        particles.len(),
        s.radius,
        a.width,
        a.height,
        gpu.info.name,
        a.out.display()
    );
    eprintln!("camera: --camera {}", camera.to_arg());
    if a.timings {
        println!("median of {} frames after {} warm-up frames", a.frames.max(1), a.warmup);
        println!("| pass | GPU ms |\n|---|---:|");
        for (name, ms) in &times.0 {
            println!("| {name} | {ms:.3} |");
        }
        println!("| **total** | **{:.3}** |", times.total());
    }
    dump(&r, a, &view)?;
    if gpu.validation().errors() > 0 {
        bail!("{} Vulkan validation errors", gpu.validation().errors());
    }
    Ok(())
}

fn dump(r: &Renderer, a: &RenderArgs, view: &View) -> Result<()> {
    let Some(t) = r.targets.as_ref() else { return Ok(()) };
    let stem = a.out.with_extension("");
    let path = |n: &str, ext: &str| PathBuf::from(format!("{}.{n}.{ext}", stem.display()));
    for d in &a.dump {
        match d.as_str() {
            "depth" | "smoothed" | "thickness" => {
                let img = match d.as_str() {
                    "depth" => &t.depth,
                    "smoothed" => r.smoothed_depth().expect("rendered"),
                    _ => &t.thickness,
                };
                let data = read_f32(&r.gpu, img)?;
                let p = path(d, "npy");
                meniscus::output::write_npy(&p, &[img.extent.height as usize, img.extent.width as usize], &data)?;
                eprintln!("wrote {}", p.display());
            }
            "normals" => {
                let raw = meniscus::renderer::read_image(&r.gpu, &t.normals)?;
                let words: Vec<u32> = bytemuck::pod_collect_to_vec(&raw);
                let mut data = Vec::with_capacity(words.len() * 3);
                for w in words {
                    let n = if w == 0 { [0.0; 3] } else { meniscus::passes::normals::unpack(w) };
                    data.extend_from_slice(&n);
                }
                let p = path(d, "npy");
                meniscus::output::write_npy(&p, &[view.height as usize, view.width as usize, 3], &data)?;
                eprintln!("wrote {}", p.display());
            }
            _ => {} // "final" is the PNG itself
        }
    }
    Ok(())
}

fn info(file: &Path) -> Result<()> {
    let bytes = std::fs::read(file).with_context(|| format!("{}", file.display()))?;
    let format = scene::detect_format(file, &bytes);
    let p = scene::load(file)?;
    println!("file:        {}", file.display());
    println!("format:      {:?}{}", format.unwrap(), if bytes.starts_with(&[0x1f, 0x8b]) { " (gzip)" } else { "" });
    println!("particles:   {}", p.len());
    println!("attributes:  position{}", p.attribute_names().iter().map(|a| format!(", {a}")).collect::<String>());
    let full = scene::percentile_bounds(&p.positions, 0.0).context("no finite positions")?;
    let pct = scene::percentile_bounds(&p.positions, 0.01).context("no finite positions")?;
    println!("bounds:      min {:?} max {:?}", full.lo.to_array(), full.hi.to_array());
    println!("1–99 %:      min {:?} max {:?}", pct.lo.to_array(), pct.hi.to_array());
    match scene::estimate_spacing(&p.positions) {
        Some(sp) => println!("spacing:     {sp:.5} (median nearest neighbour) → suggested --radius {:.5}", sp * 0.5),
        None => println!("spacing:     unknown (too few distinct particles)"),
    }
    Ok(())
}
