//! `meniscus info`: what a particle file (or the first frame of a sequence) holds — format, count, attributes,
//! bounds, spacing — and the job line every other subcommand would start from (radius estimate included).

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;

use meniscus::renderer::Upload;
use meniscus::scene;

use crate::args::{LoadArgs, SceneArgs};
use crate::job::{Job, Select};

/// `meniscus info`.
#[derive(Args, Clone, Debug)]
pub struct InfoArgs {
    /// A particle file, or a sequence (pattern with {}, folder, glob, .pvd): then its frames are listed and the
    /// first one described.
    #[arg(required_unless_present = "device")]
    pub file: Option<String>,
    /// Describe the Vulkan device instead (or the first whose name contains NAME): driver, limits, queue
    /// families and the queues Meniscus chose (main, async compute), and every GPU allocation a default frame
    /// makes (the wave scene at 960×540 with the default settings), by name, with the total.
    #[arg(long, num_args = 0..=1, value_name = "NAME")]
    pub device: Option<Option<String>>,
    /// Particle radius to report instead of the estimate.
    #[arg(long, value_parser = crate::args::finite::<f32>, allow_negative_numbers = true)]
    pub radius: Option<f32>,
    #[command(flatten)]
    pub load: LoadArgs,
}

/// Describe the file.
pub fn run(a: &InfoArgs) -> Result<()> {
    if let Some(filter) = &a.device {
        return device(filter.clone());
    }
    let input = a.file.clone().unwrap_or_default();
    let scene_args = SceneArgs {
        input: input.clone(),
        radius: a.radius,
        particles: None,
        camera: None,
        background_obj: None,
        no_scene_json: false,
    };
    let t0 = std::time::Instant::now();
    let job = match Job::open(&scene_args, &a.load, meniscus::settings::Settings::default(), Select::default()) {
        Ok(job) => job,
        Err(e) => {
            // A single file without particles is a valid file (the job refuses it: nothing to fit a camera or
            // radius to): described; any other failure stands.
            let path = std::path::Path::new(&input);
            if !scene::sequence::is_sequence(&input) && path.is_file() {
                if let Ok(p) = scene::load_with(path, &a.load.options()?) {
                    if p.is_empty() {
                        describe_file(path, t0.elapsed().as_secs_f64() * 1e3)?;
                        println!("particles:   0");
                        println!("attributes:  {}", p.attribute_names().join(", "));
                        println!("bounds:      none (the file holds no particles)");
                        return Ok(());
                    }
                }
            }
            return Err(e);
        }
    };
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    let file = match &job.frames {
        Some(frames) => {
            println!(
                "sequence:    {} frames, numbers {} … {}",
                frames.len(),
                frames[0].number,
                frames[frames.len() - 1].number
            );
            println!("first file:  {}", frames[0].path.display());
            frames[0].path.clone()
        }
        None => PathBuf::from(&input),
    };
    let p = &job.first;
    if file.exists() {
        describe_file(&file, ms)?;
    }
    println!("particles:   {}", p.len());
    println!("attributes:  position{}", p.attribute_names().iter().map(|a| format!(", {a}")).collect::<String>());
    let full = scene::percentile_bounds(&p.positions, 0.0).context("no finite positions")?;
    let pct = &job.bounds;
    println!("bounds:      min {:?} max {:?}", full.lo.to_array(), full.hi.to_array());
    println!(
        "1–99 %:      min {:?} max {:?}  (a much smaller box than min/max means stray particles)",
        pct.lo.to_array(),
        pct.hi.to_array()
    );
    match scene::estimate_spacing(&p.positions) {
        Some(sp) => println!("spacing:     {sp:.5} (median nearest neighbour)"),
        None => println!("spacing:     unknown (too few distinct particles)"),
    }
    println!("radius:      {:.5} ({:?}) → --radius {:.5}", job.settings.radius, job.radius_from, job.settings.radius);
    eprintln!("{}", job.summary(None));
    Ok(())
}

/// The file's name, size and format lines.
fn describe_file(file: &std::path::Path, ms: f64) -> Result<()> {
    let bytes = meniscus::input::read(file)?;
    let format = scene::detect_format(file, &bytes);
    println!("file:        {} ({} bytes, loaded and analysed in {ms:.1} ms)", file.display(), bytes.len());
    println!(
        "format:      {}{}",
        format.map(|f| f.name()).unwrap_or("?"),
        if bytes.starts_with(&[0x1f, 0x8b]) { " (gzip)" } else { "" }
    );
    Ok(())
}

/// `meniscus info --device [NAME]`.
fn device(filter: Option<String>) -> Result<()> {
    let gpu = crate::args::GpuArgs { validation: false, device: filter, no_int64_atomics: false }.open()?;
    let i = &gpu.info;
    println!("device:      {} ({})", i.name, i.device_type);
    println!("driver:      {}", i.driver);
    println!("vulkan:      {}", i.api_version);
    println!(
        "subgroup:    {}{}",
        i.subgroup_size,
        match i.shuffle_lanes(32) {
            1 => String::new(),
            n => format!(" (shuffles in compute: the iso cast's queued rays take up to {n} lanes each)"),
        }
    );
    println!("timestamps:  {} valid bits, {} ns per tick", i.timestamp_valid_bits, i.timestamp_period);
    let families = unsafe { gpu.instance.get_physical_device_queue_family_properties(gpu.physical) };
    for (k, f) in families.iter().enumerate() {
        println!(
            "family {k}:    {} queue(s), {:?}, timestamps {} bits",
            f.queue_count, f.queue_flags, f.timestamp_valid_bits
        );
    }
    println!("queues:      {}", gpu.queues.describe());
    println!(
        "calibrated timestamps: {} (the per-queue spans of a split frame share the device time domain)",
        if i.calibrated_timestamps { "enabled" } else { "not available" }
    );
    println!(
        "64-bit buffer atomics: {} (the iso deposit: {})",
        if i.int64_atomics { "enabled" } else { "off" },
        if i.int64_atomics { "one 64-bit atomic per voxel" } else { "two 32-bit atomics per voxel" }
    );
    println!(
        "pipeline statistics: {} (bench's per-pass compute invocations)",
        if i.pipeline_statistics { "enabled" } else { "not available" }
    );
    println!(
        "mesh shaders: {} (VK_EXT_mesh_shader; not used yet)",
        if i.mesh_shader { "offered" } else { "not offered" }
    );
    // What a default frame holds on this device: every allocation by name (the renderer's images, the particle
    // buffer, the iso grid and the smoothed field's lattice).
    let g = scene::procedural::generate("wave", 143_944)?;
    let s = meniscus::settings::Settings { radius: g.radius, ..Default::default() };
    let bounds = scene::percentile_bounds(&g.particles.positions, 0.01).context("the wave scene has no particles")?;
    let (w, h) = (960, 540);
    let camera = scene::camera::Camera::fit(&bounds, w as f32 / h as f32);
    let view = meniscus::view::View {
        camera,
        width: w,
        height: h,
        env: meniscus::view::Environment::around(&bounds, s.radius, &s),
    };
    let mut r = meniscus::renderer::Renderer::new(&gpu)?;
    r.upload(Upload::scene(&g.particles, &s))?;
    r.render(&view, &s)?;
    println!(
        "\nGPU memory of a default frame (wave scene, {} particles, {w}×{h}, default settings):\n",
        g.particles.len()
    );
    print!("{}", gpu.memory_report().table());
    Ok(())
}
