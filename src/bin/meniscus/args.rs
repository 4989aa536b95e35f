//! Argument groups shared by the subcommands, each declared once and flattened where it applies: what to
//! render ([`SceneArgs`]), how to read files ([`LoadArgs`]), settings ([`SettingsArgs`]) and the GPU
//! ([`GpuArgs`]).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{bail, Context, Result};
use clap::builder::{PossibleValuesParser, TypedValueParser};
use clap::Args;

use meniscus::device::{Gpu, GpuOptions};
use meniscus::named::{from_name, Filter, Named, SplatMode};
use meniscus::output::FileKind;
use meniscus::scene;
use meniscus::settings::{Kernel, Settings, Surface};

/// A clap value parser for a library enum: its names are the possible values (listed in `--help`).
pub fn named<T: Named + Send + Sync>() -> impl TypedValueParser<Value = T> {
    PossibleValuesParser::new(T::NAMES).map(|s| from_name::<T>(&s).expect("clap checked the possible values"))
}

/// The value parser of every floating-point flag: a number that is finite. `nan`, `inf` and `1e39` (infinite
/// as an f32) are refused by name before any work starts, so no flag carries a non-finite value into a job.
pub fn finite<T: std::str::FromStr + Into<f64> + Copy>(s: &str) -> Result<T, String> {
    let v: T = s.trim().parse().map_err(|_| format!("{s:?} is not a number"))?;
    if !v.into().is_finite() {
        return Err(format!("{s:?} is not a finite number"));
    }
    Ok(v)
}

/// How to read particle files: attribute names, up axis, unit scale.
#[derive(Args, Clone, Debug)]
pub struct LoadArgs {
    /// Attribute holding the velocity (default: velocity, v, vel).
    #[arg(long, value_name = "NAME")]
    pub velocity_attr: Option<String>,
    /// Attribute holding the density (default: density, rho).
    #[arg(long, value_name = "NAME")]
    pub density_attr: Option<String>,
    /// Attribute holding the particle id (default: id).
    #[arg(long, value_name = "NAME")]
    pub id_attr: Option<String>,
    /// Attribute holding a per-particle radius (default: radius, pscale); used for splatting when present.
    #[arg(long, value_name = "NAME")]
    pub radius_attr: Option<String>,
    /// The file's up axis (z-up data, e.g. from Blender, is turned to y-up).
    #[arg(long, value_parser = ["y", "z"], default_value = "y")]
    pub up: String,
    /// Multiply positions, radii and velocities by this (unit conversion).
    #[arg(long, value_parser = crate::args::finite::<f32>, allow_negative_numbers = true, default_value_t = 1.0)]
    pub scale: f32,
}

impl LoadArgs {
    /// The library's load options.
    pub fn options(&self) -> Result<scene::LoadOptions> {
        let mut o = scene::LoadOptions::default();
        let mut o_required = vec![];
        let mut set = |v: &mut Vec<String>, name: &Option<String>, flag: &'static str, comps: usize| {
            if let Some(n) = name {
                *v = vec![n.clone()];
                o_required.push((flag, n.clone(), comps));
            }
        };
        set(&mut o.velocity, &self.velocity_attr, "--velocity-attr", 3);
        set(&mut o.density, &self.density_attr, "--density-attr", 1);
        set(&mut o.id, &self.id_attr, "--id-attr", 1);
        set(&mut o.radius, &self.radius_attr, "--radius-attr", 1);
        o.required = o_required;
        o.z_up = self.up == "z";
        // Unit conversions span km → µm; beyond that the particles' spacing leaves 32-bit floats (1e-20 makes
        // every particle one point: an empty picture).
        if !(self.scale.is_finite() && (1e-6..=1e6).contains(&self.scale)) {
            bail!("--scale {:e}: expected a unit conversion factor in [1e-6, 1e6]", self.scale);
        }
        o.scale = self.scale;
        Ok(o)
    }
}

/// What to render and from where it is seen.
#[derive(Args, Clone, Debug)]
pub struct SceneArgs {
    /// A built-in scene, a particle file (format detected from the content), or a sequence.
    #[arg(default_value = "wave", long_help = input_help())]
    pub input: String,
    /// Particle radius in world units (default: from the scene, or estimated from the particles' density).
    #[arg(long, value_parser = crate::args::finite::<f32>, allow_negative_numbers = true)]
    pub radius: Option<f32>,
    /// Particle count of a built-in scene (default: the scene's own).
    #[arg(long)]
    pub particles: Option<usize>,
    /// Camera as EYE:TARGET[:FOVY_DEG], e.g. 0,2.5,6:0,0.3,0:45 (default: fitted to the particles; C in the
    /// demo prints the current one).
    #[arg(long, allow_hyphen_values = true)]
    pub camera: Option<String>,
    /// A triangle mesh (OBJ, world coordinates of the particles) added to the background scene: it is
    /// reflected, refracted and casts shadows on the ground. Under `demo --sim` it is also a collider of the water.
    #[arg(long, value_name = "FILE")]
    pub background_obj: Option<PathBuf>,
    /// Ignore a SPlisHSPlasH `scene.json` beside the particle files (or one folder up); by default its particle
    /// radius is used when --radius is absent and its container is drawn as walls (the shared sequences and
    /// `meniscus sim --export` have one).
    #[arg(long)]
    pub no_scene_json: bool,
}

/// The long help of the input argument, from the scene list and the format registry.
fn input_help() -> String {
    let scenes: Vec<&str> = meniscus::scene::procedural::SCENES.iter().map(|s| s.0).collect();
    format!(
        "A built-in scene ({}), a particle file — {}; detected from the content — or a sequence: a pattern with {{}} \
         for the frame number (ParticleData_Fluid_{{}}.bgeo), a folder, or a glob ('frames/*.vtk').",
        scenes.join(", "),
        meniscus::scene::format::describe()
    )
}

/// Settings: a preset, a TOML file over it, and the most used fields as flags.
#[derive(Args, Clone, Debug)]
pub struct SettingsArgs {
    /// Settings preset: default (ray-cast SPH iso-surface, its field smoothed in 3D where the water is calm),
    /// fast (particle spheres + narrow-range filter), quality (the exact SPH iso-surface, unsmoothed), smooth (the marching-cubes mesh with 25 Laplacian smoothing iterations, as splashsurf users finish it;
    /// extracted and smoothed on the GPU in the frame where the device is one, else on the CPU whenever the particles change), moritz (the thesis' curvature flow).
    #[arg(long, default_value = "default")]
    pub preset: String,
    /// TOML file of settings applied over the preset, one section per pass, e.g. `[filter.narrow]` then
    /// `radius = 8.0` (README: Settings).
    #[arg(long)]
    pub settings: Option<PathBuf>,
    /// Depth smoothing filter.
    #[arg(long, value_parser = named::<Filter>())]
    pub filter: Option<Filter>,
    /// Fluid resolution relative to the output: 1, 0.5 or 0.25 (upsampled silhouette-aware).
    #[arg(long, value_parser = crate::args::finite::<f32>, allow_negative_numbers = true)]
    pub fluid_scale: Option<f32>,
    /// Fluid depth: the ray-cast SPH iso-surface (the default: the surface splashsurf reconstructs; `[iso]
    /// smoothing` in a settings file), nearest particle spheres (then narrow-range unless --filter says
    /// otherwise), or the marching-cubes mesh.
    #[arg(long, value_parser = named::<Surface>())]
    pub surface: Option<Surface>,
    /// The iso field's kernel: isotropic (splashsurf's spheres) or anisotropic (Yu & Turk 2013: ellipsoids from
    /// each particle's neighbours, flat where the water is calm; `[anisotropy]` in a settings file).
    #[arg(long, value_parser = named::<Kernel>())]
    pub kernel: Option<Kernel>,
    /// How the depth splat draws (compute is the default; the rasterised variants exist to be measured).
    #[arg(long, value_parser = named::<SplatMode>())]
    pub splat: Option<SplatMode>,
}

impl SettingsArgs {
    /// The drawing flags given (`--fluid-scale`, `--filter`, `--surface`, `--kernel`, `--splat`), for a command
    /// that draws nothing to refuse rather than ignore.
    pub fn drawing_flags(&self) -> Vec<&'static str> {
        let given = [
            ("--fluid-scale", self.fluid_scale.is_some()),
            ("--filter", self.filter.is_some()),
            ("--surface", self.surface.is_some()),
            ("--kernel", self.kernel.is_some()),
            ("--splat", self.splat.is_some()),
        ];
        given.into_iter().filter(|(_, on)| *on).map(|(f, _)| f).collect()
    }

    /// Preset, then the TOML file, then the flags (the radius is the job's to set).
    pub fn resolve(&self) -> Result<Settings> {
        let mut s = Settings::preset(&self.preset)?;
        if let Some(f) = &self.settings {
            s = settings_file(&s, f)?;
        }
        // The surface before the filter: --surface spheres alone on an unfiltered preset gets narrow-range
        // (Settings::set_surface); an explicit --filter wins.
        if let Some(m) = self.surface {
            s.set_surface(m);
        }
        if let Some(f) = self.filter {
            s.filter.method = f;
        }
        if let Some(fs) = self.fluid_scale {
            s.fluid_scale = fs;
        }
        if let Some(m) = self.splat {
            s.splat.mode = m;
        }
        if let Some(k) = self.kernel {
            s.kernel = k;
        }
        Ok(s)
    }
}

/// Which GPU, and whether the validation layer watches it.
#[derive(Args, Clone, Debug)]
pub struct GpuArgs {
    /// Enable the Vulkan validation layer with synchronization validation (also MENISCUS_VALIDATION=1); any
    /// validation error or warning fails the run at its end.
    #[arg(long)]
    pub validation: bool,
    /// Use the first device whose name contains this (also MENISCUS_DEVICE).
    #[arg(long)]
    pub device: Option<String>,
    /// Leave 64-bit buffer atomics off where the device has them (the iso deposit then adds a voxel's two sums
    /// with two 32-bit atomics, as on devices without them): to compare the two paths.
    #[arg(long)]
    pub no_int64_atomics: bool,
}

impl GpuArgs {
    /// Open the device.
    pub fn open(&self) -> Result<Arc<Gpu>> {
        Ok(Gpu::new(&GpuOptions {
            validation: self.validation,
            device_filter: self.device.clone(),
            no_int64_atomics: self.no_int64_atomics,
            ..Default::default()
        })?)
    }
}

/// The end-of-run check of every subcommand: validation errors or warnings fail the run.
pub fn finish(gpu: &Gpu) -> Result<()> {
    let v = gpu.validation();
    if v.errors() + v.warnings() > 0 {
        bail!("{} Vulkan validation errors, {} warnings", v.errors(), v.warnings());
    }
    Ok(())
}

/// `s` with the settings file `f` over it; a key the file spells the deprecated way is a warning on stderr.
pub fn settings_file(s: &Settings, f: &Path) -> Result<Settings> {
    let mut notes = vec![];
    let s = s.with_toml_noting(f, &mut notes)?;
    for n in notes {
        eprintln!("warning: {n}");
    }
    Ok(s)
}

/// `WIDTHxHEIGHT`, each 1 … 16384.
pub fn parse_resolution(r: &str) -> Result<(u32, u32)> {
    let (w, h) = r.split_once(['x', 'X']).with_context(|| format!("bad resolution {r:?}: expected WIDTHxHEIGHT"))?;
    let w: u32 = w.trim().parse().with_context(|| format!("bad width in {r:?}"))?;
    let h: u32 = h.trim().parse().with_context(|| format!("bad height in {r:?}"))?;
    check_size(w, h)?;
    Ok((w, h))
}

/// An output or window size in range.
pub fn check_size(w: u32, h: u32) -> Result<()> {
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        bail!("size {w}×{h} is out of range (1 … 16384 each)");
    }
    Ok(())
}

/// Check an output flag's path before any work is done: what [`meniscus::output::check_output`] refuses (an
/// input of the run, an extension that is not `kind`'s, an existing file of another kind), named by the flag.
pub fn check_out(flag: &str, path: &Path, kind: FileKind) -> Result<()> {
    meniscus::output::check_output(path, kind).with_context(|| flag.to_string())
}

/// [`check_out`] for a report beside the main output (`--json`, `--markdown`, `--chart`): its folder must exist
/// already — a report is never the reason to create folders (`--chart /nonexistent/dir/c.png` is an error, not a
/// new `/nonexistent`).
pub fn check_report(flag: &str, path: &Path, kind: FileKind) -> Result<()> {
    check_out(flag, path, kind)?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        if !dir.is_dir() {
            bail!("{flag} {}: the folder {} does not exist (create it first)", path.display(), dir.display());
        }
    }
    Ok(())
}

/// A sequence write makes a new cache: refuse when any of its frames exists already (they belong to another
/// run, which this one would replace), unless the user said `--overwrite`. Names the count and the first.
pub fn refuse_existing(flag: &str, paths: &[std::path::PathBuf], overwrite: bool) -> Result<()> {
    if overwrite {
        return Ok(());
    }
    let existing: Vec<&std::path::PathBuf> = paths.iter().filter(|p| std::fs::symlink_metadata(p).is_ok()).collect();
    if let Some(first) = existing.first() {
        bail!(
            "{flag}: {} of the {} files to write exist already (first: {}); writing would replace another \
             run's cache. Pass --overwrite to replace them, or choose another name or folder",
            existing.len(),
            paths.len(),
            first.display()
        );
    }
    Ok(())
}

/// The kind among `choices` that an output flag's extension names, or an error naming the flag.
pub fn out_kind(flag: &str, path: &Path, choices: &[FileKind]) -> Result<FileKind> {
    FileKind::by_extension(path, choices).with_context(|| flag.to_string())
}

/// The numbered outputs of a sequence: `{}` in `out` is the frame number (4 digits); a folder (an existing one,
/// or a name ending in `/`) gets `frame_{}.EXT` inside; otherwise `_NNNN` goes before the extension.
pub struct Numbered {
    pattern: String,
}

impl Numbered {
    /// The pattern of `out`, with `ext` (e.g. "png") for a folder or a name without an extension.
    pub fn new(out: &Path, ext: &str) -> Numbered {
        let s = out.to_string_lossy();
        let pattern = if s.contains("{}") {
            s.into_owned()
        } else if s.ends_with('/') || out.is_dir() {
            out.join(format!("frame_{{}}.{ext}")).to_string_lossy().into_owned()
        } else {
            let e = out.extension().map(|e| e.to_string_lossy().into_owned()).unwrap_or_else(|| ext.into());
            format!("{}_{{}}.{e}", out.with_extension("").display())
        };
        Numbered { pattern }
    }

    /// The output of frame `n`.
    pub fn path(&self, n: u64) -> PathBuf {
        PathBuf::from(self.pattern.replace("{}", &format!("{n:04}")))
    }
}

/// A single output given as a folder (an existing one, or a name ending in `/`) gets `name` inside it.
pub fn single_out(out: &Path, name: &str) -> PathBuf {
    if out.to_string_lossy().ends_with('/') || out.is_dir() {
        out.join(name)
    } else {
        out.to_path_buf()
    }
}

/// The progress bar of long work: count, rate, elapsed and the estimated time left (hidden when stderr is not
/// a terminal; the commands print a summary line either way).
pub fn progress(len: u64, unit: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(len);
    bar.set_style(
        indicatif::ProgressStyle::with_template(&format!(
            "{{bar:40}} {{pos}}/{{len}} {unit}  {{per_sec:.2}}  {{msg}}  [{{elapsed}} < {{eta}}]"
        ))
        .expect("template"),
    );
    bar
}
