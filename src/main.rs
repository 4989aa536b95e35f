//! `meniscus` — the command line: `render` (headless to PNG), `info` (what a particle file holds),
//! `scenes` (the built-in scenes).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand};

use meniscus::frame::{Environment, View};
use meniscus::gpu::{Gpu, GpuOptions};
use meniscus::renderer::{read_f32, Renderer};
use meniscus::scene::{self, procedural, Camera, Particles};
use meniscus::settings::{Filter, Settings, SplatMode, Surface};

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
        /// A particle file, or a sequence (pattern with {}, folder, glob): then its frames are listed and the
        /// first one described.
        file: String,
        #[command(flatten)]
        load: LoadArgs,
    },
    /// List the built-in procedural scenes.
    Scenes,
    /// Benchmark: scenes × resolutions, per-pass GPU medians/p95/min, memory; markdown table + JSON.
    Bench(BenchArgs),
    /// Interactive window: play a sequence, fly the camera, look inside every pass.
    #[command(after_help = meniscus::demo::HELP)]
    Demo(DemoArgs),
}

#[derive(Args, Clone)]
struct DemoArgs {
    #[command(flatten)]
    scene: SceneArgs,
    #[arg(long, default_value_t = 1280)]
    width: u32,
    #[arg(long, default_value_t = 720)]
    height: u32,
    #[command(flatten)]
    set: SettingsArgs,
    /// Playback rate of a sequence in frames per second (before the speed factor).
    #[arg(long, allow_negative_numbers = true, default_value_t = 25.0)]
    fps: f32,
    /// Present without vsync (IMMEDIATE or MAILBOX when the driver has them).
    #[arg(long)]
    no_vsync: bool,
    /// Scripted run: draw this many frames, then exit.
    #[arg(long)]
    frames: Option<u64>,
    /// With --frames: write the last frame here (PNG).
    #[arg(long)]
    screenshot: Option<PathBuf>,
    #[command(flatten)]
    load: LoadArgs,
    #[arg(long)]
    validation: bool,
    #[arg(long)]
    device: Option<String>,
}

#[derive(Args, Clone)]
struct BenchArgs {
    /// Settings preset: default, fast, moritz (curvature flow ≤ 60 iterations, SSR stride 8 / 100 steps /
    /// 4 refinements, fluid ≈ ¼ of the screen, Moritz's five workloads at 1920×1080 and 960×540 unless
    /// --scenes/--resolutions say otherwise), table43 (the moritz settings with the five SSR settings of
    /// Moritz table 4.3, wave scene, 1920×1080).
    #[arg(long, default_value = "default")]
    preset: String,
    /// Comma-separated workloads: wave, crown1 (38,146), crown2 (157,944), waterfall (819,417), worst (a block
    /// filling the screen), any built-in scene as NAME or NAME:COUNT, or a particle file.
    #[arg(long, value_delimiter = ',')]
    scenes: Vec<String>,
    /// Comma-separated WIDTHxHEIGHT list.
    #[arg(long, value_delimiter = ',')]
    resolutions: Vec<String>,
    /// Frames rendered before measuring (lavapipe compiles pipelines at first use).
    #[arg(long, default_value_t = 3)]
    warmup: u32,
    /// Measured frames.
    #[arg(long, default_value_t = 10)]
    frames: u32,
    /// Particle radius for file workloads (default: estimated from the spacing).
    #[arg(long, allow_negative_numbers = true)]
    radius: Option<f32>,
    /// Camera for file workloads, EYE:TARGET[:FOVY] (default: fitted).
    #[arg(long, allow_hyphen_values = true)]
    camera: Option<String>,
    /// Also measure design variants on the first workload and resolution (same run, so ratios compare):
    /// each splat mode (compute, quads/points with gl_FragDepth, conservative depth, MIN blending), each
    /// smoothing filter, curvature flow 1 vs 4 iterations per dispatch.
    #[arg(long)]
    variants: bool,
    /// Write the JSON report here (schema: benches/README.md).
    #[arg(long)]
    json: Option<PathBuf>,
    /// Reuse the static background while the camera stays (as `render` of a sequence does) instead of
    /// re-rendering it every measured frame.
    #[arg(long)]
    cache_background: bool,
    /// Write the markdown table here too.
    #[arg(long)]
    markdown: Option<PathBuf>,
    /// Scaling sweeps instead of the scene list: `particles` (wave scene, 10k → 4M particles at fixed screen
    /// coverage, first resolution), `pixels` (wave scene, 480p → 4K), or `both`.
    #[arg(long, value_parser = ["particles", "pixels", "both"])]
    sweep: Option<String>,
    /// With --sweep: particle counts (comma-separated) instead of 10k, 40k, 160k, 640k, 2.56M, 4M.
    #[arg(long, value_delimiter = ',')]
    sweep_particles: Vec<usize>,
    /// With --sweep: write the chart (per-pass ms against particles and pixels) as PNG here.
    #[arg(long)]
    chart: Option<PathBuf>,
    /// TOML settings over the preset.
    #[arg(long)]
    settings: Option<PathBuf>,
    #[arg(long)]
    validation: bool,
    #[arg(long)]
    device: Option<String>,
}

/// How to read particle files: attribute names, up axis, unit scale.
#[derive(Args, Clone)]
struct LoadArgs {
    /// Attribute holding the velocity (default: velocity, v, vel).
    #[arg(long, value_name = "NAME")]
    velocity_attr: Option<String>,
    /// Attribute holding the density (default: density, rho).
    #[arg(long, value_name = "NAME")]
    density_attr: Option<String>,
    /// Attribute holding the particle id (default: id).
    #[arg(long, value_name = "NAME")]
    id_attr: Option<String>,
    /// Attribute holding a per-particle radius (default: radius, pscale); used for splatting when present.
    #[arg(long, value_name = "NAME")]
    radius_attr: Option<String>,
    /// The file's up axis (z-up data, e.g. from Blender, is turned to y-up).
    #[arg(long, value_parser = ["y", "z"], default_value = "y")]
    up: String,
    /// Multiply positions, radii and velocities by this (unit conversion).
    #[arg(long, allow_negative_numbers = true, default_value_t = 1.0)]
    scale: f32,
}

impl LoadArgs {
    fn options(&self) -> Result<scene::LoadOptions> {
        let mut o = scene::LoadOptions::default();
        let set = |v: &mut Vec<String>, name: &Option<String>| {
            if let Some(n) = name {
                *v = vec![n.clone()];
            }
        };
        set(&mut o.velocity, &self.velocity_attr);
        set(&mut o.density, &self.density_attr);
        set(&mut o.id, &self.id_attr);
        set(&mut o.radius, &self.radius_attr);
        o.z_up = self.up == "z";
        if !(self.scale.is_finite() && self.scale > 0.0) {
            bail!("--scale must be a positive number");
        }
        o.scale = self.scale;
        Ok(o)
    }
}

/// What to render and from where it is seen (shared by render and demo).
#[derive(Args, Clone)]
struct SceneArgs {
    /// A built-in scene (block, wave, drop, crown, waterfall), a particle file (.bgeo, .vtk, .vtu/.vtp, .ply,
    /// .xyz, .csv, RealFlow .bin; detected from the content), or a sequence: a pattern with {} for the frame
    /// number (ParticleData_Fluid_{}.bgeo), a folder, or a glob ('frames/*.vtk').
    #[arg(default_value = "wave")]
    input: String,
    /// Particle radius in world units (default: from the scene, or half the median particle spacing).
    #[arg(long, allow_negative_numbers = true)]
    radius: Option<f32>,
    /// Particle count of a built-in scene (default: the scene's own).
    #[arg(long)]
    particles: Option<usize>,
    /// Camera as EYE:TARGET[:FOVY_DEG], e.g. 0,2.5,6:0,0.3,0:45 (default: fitted to the particles; C in the
    /// demo prints the current one).
    #[arg(long, allow_hyphen_values = true)]
    camera: Option<String>,
    /// A triangle mesh (OBJ, world coordinates of the particles) added to the background scene: it is
    /// reflected, refracted and casts shadows on the ground.
    #[arg(long, value_name = "FILE")]
    background_obj: Option<PathBuf>,
}

/// What `--skybox` and `--background-obj` add to the background, read (and checked) before the GPU starts.
struct BackgroundExtras {
    sky: Option<(u32, Vec<u8>)>,
    mesh: Option<meniscus::mesh::Mesh>,
}

impl BackgroundExtras {
    fn load(a: &RenderArgs) -> Result<Self> {
        Ok(BackgroundExtras {
            sky: a.skybox.as_deref().map(meniscus::sky::load_faces).transpose()?,
            mesh: a.scene.background_obj.as_deref().map(meniscus::mesh::Mesh::load_obj).transpose()?,
        })
    }

    /// Upload into the renderer; true when a sky cube map was loaded.
    fn apply(&self, r: &mut Renderer) -> Result<bool> {
        if let Some(m) = &self.mesh {
            r.set_background_mesh(m)?;
        }
        if let Some((size, faces)) = &self.sky {
            r.set_skybox(*size, faces)?;
        }
        Ok(self.sky.is_some())
    }
}

/// Settings: a preset, a TOML file over it, and the most used fields as flags.
#[derive(Args, Clone)]
struct SettingsArgs {
    /// Settings preset: default (spheres + narrow-range), fast, quality (ray-cast SPH iso-surface, unfiltered),
    /// moritz (the thesis' curvature flow).
    #[arg(long, default_value = "default")]
    preset: String,
    /// TOML file of settings applied over the preset (any field of src/settings.rs, e.g. `nrf_radius = 8.0`).
    #[arg(long)]
    settings: Option<PathBuf>,
    /// Depth smoothing filter.
    #[arg(long, value_enum)]
    filter: Option<Filter>,
    /// Fluid resolution relative to the output: 1, 0.5 or 0.25 (upsampled silhouette-aware).
    #[arg(long, allow_negative_numbers = true)]
    fluid_scale: Option<f32>,
    /// Fluid depth: nearest particle spheres (fast), or the ray-cast SPH iso-surface (the surface splashsurf
    /// reconstructs; a filter only blurs it: use --filter none, or --preset quality).
    #[arg(long, value_enum)]
    surface: Option<Surface>,
    /// How the depth splat draws (compute is the default; the rasterised variants exist to be measured).
    #[arg(long, value_enum)]
    splat: Option<SplatMode>,
}

impl SettingsArgs {
    fn resolve(&self, preset_override: Option<&str>) -> Result<Settings> {
        let mut s = Settings::preset(preset_override.unwrap_or(&self.preset))?;
        if let Some(f) = &self.settings {
            s = s.with_toml(f)?;
        }
        if let Some(f) = self.filter {
            s.filter = f;
        }
        if let Some(fs) = self.fluid_scale {
            s.fluid_scale = fs;
        }
        if let Some(m) = self.splat {
            s.splat = m;
        }
        if let Some(m) = self.surface {
            s.surface = m;
        }
        Ok(s)
    }
}

#[derive(Args, Clone)]
struct RenderArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Output PNG (written atomically: no half-written file on failure). For a sequence, {} in the name is the
    /// frame number (4 digits), else _NNNN is added before the extension.
    #[arg(short, long, default_value = "frame.png")]
    out: PathBuf,
    /// Sequence: frames FIRST..LAST[:STEP] (inclusive, by the numbers in the file names), e.g. 10..40:2.
    #[arg(long = "frames", value_name = "RANGE")]
    frames_range: Option<String>,
    /// Sequence: render only shard K of N (every Nth frame starting with the Kth), e.g. 2/8.
    #[arg(long)]
    shard: Option<String>,
    #[command(flatten)]
    load: LoadArgs,
    #[arg(long, default_value_t = 960)]
    width: u32,
    #[arg(long, default_value_t = 540)]
    height: u32,
    #[command(flatten)]
    set: SettingsArgs,
    /// Sky cube map from six images DIR/{px,nx,py,ny,pz,nz}.png (default: procedural sky).
    #[arg(long, value_name = "DIR")]
    skybox: Option<PathBuf>,
    /// Print a per-pass GPU time table (median over the timed frames, after warm-up).
    #[arg(long)]
    timings: bool,
    /// With --timings: frames rendered first and not timed (lavapipe compiles pipelines at first use).
    #[arg(long, default_value_t = 2)]
    warmup: u32,
    /// With --timings: frames timed; the table shows per-pass medians.
    #[arg(long = "timed-frames", default_value_t = 5)]
    frames: u32,
    /// Write buffers next to the PNG: depth, smoothed, thickness as OUT.NAME.npy (float32, H×W, +inf = none),
    /// normals as OUT.normals.npy (H×W×3, view space) and OUT.normals.png, ssr as OUT.ssr.png, final = the PNG.
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
        Cmd::Info { file, load } => info(&file, &load),
        Cmd::Bench(b) => bench(&b),
        Cmd::Demo(d) => demo(&d),
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
fn load_input(input: &str, count: Option<usize>, o: &scene::LoadOptions) -> Result<(Particles, Option<f32>, String)> {
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
    Ok((scene::load_with(path, o)?, None, input.to_string()))
}

fn render(a: &RenderArgs) -> Result<()> {
    let opts = a.load.options()?;
    if !procedural::SCENES.iter().any(|s| s.0 == a.scene.input)
        && meniscus::scene::sequence::is_sequence(&a.scene.input)
    {
        return render_sequence(a, &opts);
    }
    if a.frames_range.is_some() || a.shard.is_some() {
        bail!("--frames and --shard apply to sequences (a pattern with {{}}, a folder or a glob)");
    }
    let (particles, scene_radius, label) = load_input(&a.scene.input, a.scene.particles, &opts)?;
    let s = settings_for(a, &particles, scene_radius)?;
    let bounds = scene::percentile_bounds(&particles.positions, 0.01).context("no finite particle positions")?;
    let camera = match &a.scene.camera {
        Some(c) => Camera::parse(c)?,
        None => Camera::fit(&bounds, a.width as f32 / a.height.max(1) as f32),
    };
    let mut view = View { camera, width: a.width, height: a.height, env: Environment::around(&bounds, s.radius, &s) };
    check_dumps(a)?;
    let extras = BackgroundExtras::load(a)?;
    let gpu =
        Gpu::new(&GpuOptions { validation: a.validation, device_filter: a.device.clone(), ..Default::default() })?;
    let mut r = Renderer::new(&gpu)?;
    view.env.sky_cube = extras.apply(&mut r)?;
    r.keep_raw_depth = a.dump.iter().any(|d| d == "depth");
    upload(&mut r, &particles, &s)?;
    // Timed frames re-render the static background too, so the table shows every pass.
    r.always_render_background = a.timings;
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

fn check_dumps(a: &RenderArgs) -> Result<()> {
    for d in &a.dump {
        if !["depth", "smoothed", "thickness", "normals", "ssr", "final"].contains(&d.as_str()) {
            bail!("--dump {d:?}: expected some of depth, smoothed, thickness, normals, ssr, final");
        }
    }
    Ok(())
}

/// Upload particles with their spray flags and per-particle radii (when mapped).
fn upload(r: &mut Renderer, p: &Particles, s: &Settings) -> Result<()> {
    let spray = scene::spray_mask_with(p, s.radius, s.spray_density, s.spray_by_neighbours);
    r.set_particles_with(&p.positions, p.radii.as_deref(), Some(&spray))?;
    Ok(())
}

/// Settings from preset/TOML/flags, with the radius from the flag, the scene, or the particle spacing.
fn settings_for(a: &RenderArgs, particles: &Particles, scene_radius: Option<f32>) -> Result<Settings> {
    let mut s = a.set.resolve(None)?;
    s.radius = match a.scene.radius.or(scene_radius) {
        Some(r) => r,
        None => {
            let r = scene::estimate_radius(&particles.positions)
                .context("cannot estimate the particle radius (too few distinct particles); pass --radius")?;
            eprintln!("radius {r:.5} estimated from the particle spacing (pass --radius to override)");
            r
        }
    };
    s.validate()?;
    Ok(s)
}

/// Render a sequence to numbered PNGs: background prefetch, progress bar, camera fitted once on the first frame.
fn render_sequence(a: &RenderArgs, opts: &scene::LoadOptions) -> Result<()> {
    use meniscus::scene::sequence::{self, FrameRange, Prefetch};
    let range = a.frames_range.as_deref().map(FrameRange::parse).transpose()?;
    let shard = a.shard.as_deref().map(sequence::parse_shard).transpose()?;
    let frames = sequence::resolve(&a.scene.input, range, shard)?;
    check_dumps(a)?;
    if !a.dump.is_empty() {
        bail!("--dump applies to single frames");
    }
    let out_name = |n: u64| -> PathBuf {
        let s = a.out.to_string_lossy();
        if s.contains("{}") {
            PathBuf::from(s.replace("{}", &format!("{n:04}")))
        } else {
            let stem = a.out.with_extension("");
            let ext = a.out.extension().map(|e| e.to_string_lossy().into_owned()).unwrap_or_else(|| "png".into());
            PathBuf::from(format!("{}_{n:04}.{ext}", stem.display()))
        }
    };
    let extras = BackgroundExtras::load(a)?;
    let gpu =
        Gpu::new(&GpuOptions { validation: a.validation, device_filter: a.device.clone(), ..Default::default() })?;
    let mut r = Renderer::new(&gpu)?;
    let sky_cube = extras.apply(&mut r)?;
    let total = frames.len();
    eprintln!(
        "{}: {total} frames ({} … {}) on {}",
        a.scene.input,
        frames[0].number,
        frames[total - 1].number,
        gpu.info.name
    );
    let bar = indicatif::ProgressBar::new(total as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} frames  {msg}  [{elapsed} < {eta}]")
            .expect("template"),
    );
    let mut fixed: Option<(Settings, View)> = None;
    let t0 = std::time::Instant::now();
    let mut gpu_ms = 0.0;
    for (frame, loaded) in Prefetch::start(frames, opts.clone(), 2) {
        let particles = loaded?;
        if fixed.is_none() {
            let s = settings_for(a, &particles, None)?;
            let bounds =
                scene::percentile_bounds(&particles.positions, 0.01).context("no finite particle positions")?;
            let camera = match &a.scene.camera {
                Some(c) => Camera::parse(c)?,
                None => Camera::fit(&bounds, a.width as f32 / a.height.max(1) as f32),
            };
            bar.println(format!("camera: --camera {}", camera.to_arg()));
            let mut view =
                View { camera, width: a.width, height: a.height, env: Environment::around(&bounds, s.radius, &s) };
            view.env.sky_cube = sky_cube;
            fixed = Some((s, view));
        }
        let (s, view) = fixed.as_ref().expect("set above");
        upload(&mut r, &particles, s)?;
        gpu_ms += r.render(view, s)?.total();
        let path = out_name(frame.number);
        meniscus::output::write_png(&path, &r.read_final()?)?;
        bar.set_message(format!(
            "{} → {}",
            frame.path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default(),
            path.display()
        ));
        bar.inc(1);
    }
    bar.finish();
    let secs = t0.elapsed().as_secs_f64();
    eprintln!(
        "{total} frames in {secs:.1} s ({:.2} frames/s, mean GPU frame {:.1} ms)",
        total as f64 / secs,
        gpu_ms / total as f64
    );
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
                let png = image::RgbaImage::from_fn(view.width, view.height, |x, y| {
                    let i = 3 * (y * view.width + x) as usize;
                    let c = |k: usize| ((data[i + k] * 0.5 + 0.5) * 255.0).round().clamp(0.0, 255.0) as u8;
                    if data[i..i + 3] == [0.0; 3] {
                        image::Rgba([0, 0, 0, 255])
                    } else {
                        image::Rgba([c(0), c(1), c(2), 255])
                    }
                });
                let p = path(d, "png");
                meniscus::output::write_png(&p, &png)?;
                eprintln!("wrote {}", p.display());
            }
            "ssr" => {
                // The reflected scene colour where SSR hit, black elsewhere.
                let hits: Vec<u32> = bytemuck::pod_collect_to_vec(&meniscus::renderer::read_image(&r.gpu, &t.ssr)?);
                let scene: Vec<u16> =
                    bytemuck::pod_collect_to_vec(&meniscus::renderer::read_image(&r.gpu, &t.scene_color)?);
                let (w, h) = (view.width, view.height);
                let png = image::RgbaImage::from_fn(w, h, |x, y| {
                    match meniscus::passes::ssr::decode(hits[(y * w + x) as usize]) {
                        Some([u, v]) => {
                            let sx = ((u * w as f32) as u32).min(w - 1);
                            let sy = ((v * h as f32) as u32).min(h - 1);
                            let i = 4 * (sy * w + sx) as usize;
                            let c = |k: usize| {
                                (meniscus::output::f16_to_f32(scene[i + k]).clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0)
                                    .round() as u8
                            };
                            image::Rgba([c(0), c(1), c(2), 255])
                        }
                        None => image::Rgba([0, 0, 0, 255]),
                    }
                });
                let p = path(d, "png");
                meniscus::output::write_png(&p, &png)?;
                eprintln!("wrote {}", p.display());
            }
            _ => {} // "final" is the PNG itself
        }
    }
    Ok(())
}

fn info(spec: &str, load: &LoadArgs) -> Result<()> {
    use meniscus::scene::sequence;
    let opts = load.options()?;
    let file = if sequence::is_sequence(spec) {
        let frames = sequence::resolve(spec, None, None)?;
        println!(
            "sequence:    {} frames, numbers {} … {}",
            frames.len(),
            frames[0].number,
            frames[frames.len() - 1].number
        );
        println!("first file:  {}", frames[0].path.display());
        frames[0].path.clone()
    } else {
        PathBuf::from(spec)
    };
    let bytes = std::fs::read(&file).with_context(|| format!("{}", file.display()))?;
    let format = scene::detect_format(&file, &bytes);
    let t0 = std::time::Instant::now();
    let p = scene::load_with(&file, &opts)?;
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    println!("file:        {} ({} bytes, loaded in {ms:.1} ms)", file.display(), bytes.len());
    println!(
        "format:      {}{}",
        format.map(|f| f.name()).unwrap_or("?"),
        if bytes.starts_with(&[0x1f, 0x8b]) { " (gzip)" } else { "" }
    );
    println!("particles:   {}", p.len());
    println!("attributes:  position{}", p.attribute_names().iter().map(|a| format!(", {a}")).collect::<String>());
    let full = scene::percentile_bounds(&p.positions, 0.0).context("no finite positions")?;
    let pct = scene::percentile_bounds(&p.positions, 0.01).context("no finite positions")?;
    println!("bounds:      min {:?} max {:?}", full.lo.to_array(), full.hi.to_array());
    println!(
        "1–99 %:      min {:?} max {:?}  (a much smaller box than min/max means stray particles)",
        pct.lo.to_array(),
        pct.hi.to_array()
    );
    match scene::estimate_spacing(&p.positions) {
        Some(sp) => println!("spacing:     {sp:.5} (median nearest neighbour) → suggested --radius {:.5}", sp * 0.5),
        None => println!("spacing:     unknown (too few distinct particles)"),
    }
    Ok(())
}

fn parse_resolution(r: &str) -> Result<(u32, u32)> {
    let (w, h) = r.split_once(['x', 'X']).with_context(|| format!("bad resolution {r:?}: expected WIDTHxHEIGHT"))?;
    let w: u32 = w.trim().parse().with_context(|| format!("bad width in {r:?}"))?;
    let h: u32 = h.trim().parse().with_context(|| format!("bad height in {r:?}"))?;
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        bail!("resolution {r:?} out of range (1 … 16384)");
    }
    Ok((w, h))
}

/// A workload from its command-line name.
fn workload(name: &str, a: &BenchArgs, quarter: bool) -> Result<meniscus::bench::Workload> {
    use meniscus::bench::Workload;
    let dist = if quarter { 2.0 } else { 1.0 };
    let (scene, count, distance, label) = match name {
        "wave" => ("wave", 143_944, dist, "wave".to_string()),
        "crown1" => ("crown", 38_146, dist, "crown 1".to_string()),
        "crown2" => ("crown", 157_944, dist, "crown 2".to_string()),
        "waterfall" => ("waterfall", 819_417, dist, "waterfall".to_string()),
        "worst" => ("block", 143_944, 0.55, "worst case (block fills the screen)".to_string()),
        other => {
            let (n, c) = match other.split_once(':') {
                Some((n, c)) => {
                    (n, Some(c.parse::<usize>().with_context(|| format!("bad particle count in {other:?}"))?))
                }
                None => (other, None),
            };
            if let Some((sn, def, _)) = procedural::SCENES.iter().find(|s| s.0 == n) {
                (*sn, c.unwrap_or(*def), dist, n.to_string())
            } else {
                let (p, _, label) = load_input(other, None, &scene::LoadOptions::default())?;
                let radius = match a.radius {
                    Some(r) => r,
                    None => {
                        scene::estimate_radius(&p.positions).context("cannot estimate the radius; pass --radius")?
                    }
                };
                let camera = a.camera.as_deref().map(Camera::parse).transpose()?;
                let label = Path::new(&label).file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or(label);
                return Ok(Workload { label, particles: p, radius, distance: 1.0, camera });
            }
        }
    };
    let g = procedural::generate(scene, count)?;
    Ok(Workload { label, particles: g.particles, radius: g.radius, distance, camera: None })
}

fn bench(a: &BenchArgs) -> Result<()> {
    meniscus::bench::note_start_rss();
    let table43 = a.preset == "table43";
    let moritz = a.preset == "moritz" || table43;
    let mut base = Settings::preset(if table43 { "moritz" } else { &a.preset })?;
    if let Some(f) = &a.settings {
        base = base.with_toml(f)?;
    }
    let scenes: Vec<String> = if !a.scenes.is_empty() {
        a.scenes.clone()
    } else if table43 {
        vec!["wave".into()]
    } else if moritz {
        ["wave", "crown1", "crown2", "waterfall", "worst"].map(String::from).to_vec()
    } else {
        vec!["wave".into()]
    };
    let resolutions: Vec<(u32, u32)> = if !a.resolutions.is_empty() {
        a.resolutions.iter().map(|r| parse_resolution(r)).collect::<Result<_>>()?
    } else if table43 {
        vec![(1920, 1080)]
    } else if moritz {
        vec![(1920, 1080), (960, 540)]
    } else {
        vec![(960, 540)]
    };
    let gpu =
        Gpu::new(&GpuOptions { validation: a.validation, device_filter: a.device.clone(), ..Default::default() })?;
    eprintln!("device: {} ({}), Vulkan {}", gpu.info.name, gpu.info.driver, gpu.info.api_version);
    let mut r = Renderer::new(&gpu)?;
    r.always_render_background = !a.cache_background;
    let mut variants: Vec<(String, Settings)> = vec![(a.preset.clone(), base.clone())];
    let n_var = if a.variants { 12 } else { 0 };
    let bar = indicatif::ProgressBar::new((scenes.len() * resolutions.len() + n_var) as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} {msg} [{elapsed}]").expect("valid template"),
    );
    let mut entries = vec![];
    if let Some(sweep) = &a.sweep {
        bar.finish_and_clear();
        return run_sweep(a, sweep, &gpu, &mut r, &base, resolutions[0]);
    }
    for (k, name) in scenes.iter().enumerate() {
        bar.set_message(format!("generating {name}"));
        let w = workload(name, a, moritz)?;
        for (j, &(wd, ht)) in resolutions.iter().enumerate() {
            bar.set_message(format!("{} {}×{}", w.label, wd, ht));
            if table43 {
                // Moritz table 4.3: stride / refinement iterations / max steps.
                for (stride, refine, steps) in [(1, 0, 280), (4, 0, 180), (4, 2, 180), (8, 0, 100), (8, 4, 100)] {
                    let vs = Settings {
                        ssr_stride: stride as f32,
                        ssr_refine: refine,
                        ssr_max_steps: steps,
                        ..base.clone()
                    };
                    let label = format!("ssr stride {stride}, refine {refine}, steps {steps}");
                    entries.push(meniscus::bench::measure(&mut r, &w, wd, ht, &vs, &label, a.warmup, a.frames)?);
                }
                bar.inc(1);
                continue;
            }
            entries.push(meniscus::bench::measure(&mut r, &w, wd, ht, &base, &a.preset, a.warmup, a.frames)?);
            bar.inc(1);
            if a.variants && k == 0 && j == 0 {
                variants.clear();
                for f in [Filter::Bilateral, Filter::NarrowRange, Filter::CurvatureFlow] {
                    variants.push((format!("filter {}", f.name()), Settings { filter: f, ..base.clone() }));
                }
                for kk in [1, 4] {
                    variants.push((
                        format!("curvature-flow {kk} it/dispatch"),
                        Settings { filter: Filter::CurvatureFlow, cf_iters_per_dispatch: kk, ..base.clone() },
                    ));
                }
                variants.push(("no smoothing".into(), Settings { filter: Filter::None, ..base.clone() }));
                for m in SplatMode::ALL {
                    if r.passes.splat.supports(m) {
                        variants.push((format!("splat {}", m.name()), Settings { splat: m, ..base.clone() }));
                    }
                }
                for (label, vs) in &variants {
                    bar.set_message(format!("variant {label}"));
                    entries.push(meniscus::bench::measure(&mut r, &w, wd, ht, vs, label, a.warmup, a.frames)?);
                    bar.inc(1);
                }
            }
        }
    }
    bar.finish_and_clear();
    let table = meniscus::bench::markdown(&entries);
    println!(
        "{} — {} — preset {} — commit {}\n",
        gpu.info.name,
        gpu.info.driver,
        a.preset,
        meniscus::bench::git_commit()
    );
    println!("{table}");
    if a.variants {
        let find = |v: &str| {
            entries
                .iter()
                .find(|e| e.variant == v)
                .map(|e| e.passes.iter().find(|p| p.0 == "smooth").map(|p| p.1.median).unwrap_or(0.0))
        };
        if let (Some(k1), Some(k4)) = (find("curvature-flow 1 it/dispatch"), find("curvature-flow 4 it/dispatch")) {
            println!("ratio smooth (curvature flow) 1 it/dispatch ÷ 4 it/dispatch: {:.2} (> 1: several per dispatch is faster)", k1 / k4.max(1e-9));
        }
        let splat = |v: &str| {
            entries
                .iter()
                .find(|e| e.variant == v)
                .and_then(|e| e.passes.iter().find(|p| p.0 == "splat").map(|p| p.1.median))
        };
        if let Some(fd) = splat("splat quad-frag-depth") {
            for m in ["compute", "quad-conservative", "quad-min", "point-frag-depth", "point-min"] {
                if let Some(t) = splat(&format!("splat {m}")) {
                    println!("ratio splat quad-frag-depth ÷ {m}: {:.2} (> 1: {m} is faster)", fd / t.max(1e-9));
                }
            }
        }
    }
    write_reports(a, &gpu, base, entries, &table)?;
    if gpu.validation().errors() > 0 {
        bail!("{} Vulkan validation errors", gpu.validation().errors());
    }
    Ok(())
}

/// Write the JSON report (`--json`) and the markdown table (`--markdown`) of a bench run.
fn write_reports(
    a: &BenchArgs,
    gpu: &std::sync::Arc<Gpu>,
    settings: Settings,
    entries: Vec<meniscus::bench::Entry>,
    table: &str,
) -> Result<()> {
    let report = meniscus::bench::Report {
        schema: meniscus::bench::SCHEMA,
        device: meniscus::bench::device_info(gpu),
        git_commit: meniscus::bench::git_commit(),
        preset: a.preset.clone(),
        settings,
        entries,
        rss_start_bytes: meniscus::bench::start_rss(),
        rss_end_bytes: meniscus::bench::rss_bytes(),
    };
    if let Some(p) = &a.json {
        let text = serde_json::to_string_pretty(&report)?;
        meniscus::output::write_atomic(p, |w| std::io::Write::write_all(w, text.as_bytes()))?;
        eprintln!("wrote {}", p.display());
    }
    if let Some(p) = &a.markdown {
        meniscus::output::write_atomic(p, |w| std::io::Write::write_all(w, table.as_bytes()))?;
    }
    Ok(())
}

/// Per-pass medians plus the total of an entry, for the chart.
fn chart_point(e: &meniscus::bench::Entry) -> Vec<(String, f64)> {
    let mut v: Vec<(String, f64)> = e.passes.iter().map(|(n, s)| (n.clone(), s.median)).collect();
    v.push(("total".into(), e.gpu_total.median));
    v
}

fn run_sweep(
    a: &BenchArgs,
    sweep: &str,
    gpu: &std::sync::Arc<Gpu>,
    r: &mut Renderer,
    base: &Settings,
    res: (u32, u32),
) -> Result<()> {
    use meniscus::bench::{measure, Workload};
    let counts: Vec<usize> = if a.sweep_particles.is_empty() {
        vec![10_000, 40_000, 160_000, 640_000, 2_560_000, 4_000_000]
    } else {
        a.sweep_particles.clone()
    };
    let sizes = [(854u32, 480u32), (1280, 720), (1920, 1080), (2560, 1440), (3840, 2160)];
    let do_particles = sweep == "particles" || sweep == "both";
    let do_pixels = sweep == "pixels" || sweep == "both";
    let total = if do_particles { counts.len() } else { 0 } + if do_pixels { sizes.len() } else { 0 };
    let bar = indicatif::ProgressBar::new(total as u64);
    bar.set_style(indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} {msg} [{elapsed}]").expect("template"));
    let mut entries = vec![];
    let mut panels = vec![];
    if do_particles {
        let mut pts = vec![];
        for &n in &counts {
            bar.set_message(format!("{n} particles"));
            // The same pool at every count: the camera fit keeps the screen coverage fixed.
            let g = procedural::generate("wave", n)?;
            let w = Workload {
                label: "wave".into(),
                particles: g.particles,
                radius: g.radius,
                distance: 1.0,
                camera: None,
            };
            let e = measure(r, &w, res.0, res.1, base, "sweep particles", a.warmup, a.frames)?;
            pts.push((e.particles as f64, chart_point(&e)));
            entries.push(e);
            bar.inc(1);
        }
        panels.push(("particles", pts));
    }
    if do_pixels {
        let g = procedural::generate("wave", 143_944)?;
        let w =
            Workload { label: "wave".into(), particles: g.particles, radius: g.radius, distance: 1.0, camera: None };
        let mut pts = vec![];
        for &(wd, ht) in &sizes {
            bar.set_message(format!("{wd}×{ht}"));
            let e = measure(r, &w, wd, ht, base, "sweep pixels", a.warmup, a.frames)?;
            pts.push(((wd * ht) as f64, chart_point(&e)));
            entries.push(e);
            bar.inc(1);
        }
        panels.push(("pixels", pts));
    }
    bar.finish_and_clear();
    let table = meniscus::bench::markdown(&entries);
    println!("{} — {} — preset {} — sweep {sweep}\n\n{table}", gpu.info.name, gpu.info.driver, a.preset);
    if let Some(p) = &a.chart {
        let series: Vec<meniscus::chart::Series> = panels
            .into_iter()
            .map(|(x, points)| meniscus::chart::Series {
                x_label: if x == "particles" { "particles" } else { "pixels" },
                points,
            })
            .collect();
        meniscus::chart::write(p, &format!("meniscus bench --sweep {sweep} — {}", gpu.info.name), &series)?;
        eprintln!("wrote {}", p.display());
    }
    write_reports(a, gpu, base.clone(), entries, &table)
}

fn demo(a: &DemoArgs) -> Result<()> {
    let s = a.set.resolve(None)?;
    if a.screenshot.is_some() && a.frames.is_none() {
        bail!("--screenshot needs --frames N (or press P in the window)");
    }
    if a.width == 0 || a.height == 0 || a.width > 16384 || a.height > 16384 {
        bail!("window size {}×{} is out of range", a.width, a.height);
    }
    meniscus::demo::run(meniscus::demo::DemoOptions {
        input: a.scene.input.clone(),
        particles: a.scene.particles,
        radius: a.scene.radius,
        camera: a.scene.camera.as_deref().map(Camera::parse).transpose()?,
        width: a.width,
        height: a.height,
        settings: s,
        load: a.load.options()?,
        vsync: !a.no_vsync,
        validation: a.validation,
        device: a.device.clone(),
        frames: a.frames,
        screenshot: a.screenshot.clone(),
        fps: a.fps.max(0.1),
        mesh: a.scene.background_obj.as_deref().map(meniscus::mesh::Mesh::load_obj).transpose()?,
    })?;
    Ok(())
}
