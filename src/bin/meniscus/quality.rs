//! `meniscus quality`: how good a rendered surface is, in space and in time (`meniscus::quality`). One frame: its
//! roughness (particle rows on calm water show as terraces) and, per `--reference`, its distance to a reference
//! surface's depth (splashsurf's, rasterised at the same camera). A sequence: the same per frame, and its
//! flicker from frame to frame — colour and normal change where the water stays, and the warping error along
//! the particles' velocities (Lai et al. 2018).

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::Args;

use meniscus::quality::{self, DepthImage, FlickerMeter, Picture, SurfaceMotion};
use meniscus::renderer::Renderer;
use meniscus::scene::sequence::FrameRange;

use crate::args::{check_report, check_size, finish, GpuArgs, LoadArgs, SceneArgs, SettingsArgs};
use crate::job::{Job, Select};

/// `meniscus quality`.
#[derive(Args, Clone, Debug)]
#[command(
    after_help = "Example: meniscus quality ParticleData_Fluid_20.bgeo --radius 0.0125 --camera 0,2.5,6:0,0.3,0:45 \
--reference dambreak59k_f20_ref_depth.npy --reference dambreak59k_f20_smooth_ref_depth.npy"
)]
pub struct QualityArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// A reference surface: its depth image at the same camera and size (float32 .npy, H×W, linear eye depth,
    /// +inf where empty; ../shared/data/quality holds splashsurf's), or its mesh (.obj or .ply, ray-cast at the
    /// camera). May be given more than once.
    #[arg(long, value_name = "NPY|MESH")]
    reference: Vec<PathBuf>,
    /// Measure this surface instead of rendering the particles: a depth image (.npy) or a mesh (.obj, .ply; e.g.
    /// `meniscus mesh` or splashsurf output) ray-cast at the camera. The particles still give the radius and the
    /// fitted camera.
    #[arg(long, value_name = "NPY|MESH")]
    depth: Option<PathBuf>,
    /// Write the measured surface's depth image here (.npy; one frame): a reference for later runs.
    #[arg(long, value_name = "NPY")]
    depth_out: Option<PathBuf>,
    /// Sequence: frames FIRST..LAST[:STEP] (inclusive, by the numbers in the file names), e.g. 10..40:2.
    #[arg(long = "frames", value_name = "RANGE")]
    frames_range: Option<String>,
    /// Sequence: measure the meshes `meniscus mesh` makes of each frame instead of the rendered surface (cube
    /// 0.5 r, unsmoothed and with 25 smoothing iterations): how far each frame's mesh is from the next, as it
    /// stands and moved with the particles' velocities. No GPU needed.
    #[arg(long)]
    mesh: bool,
    /// Write the figures as JSON here.
    #[arg(long, value_name = "JSON")]
    json: Option<PathBuf>,
    #[command(flatten)]
    load: LoadArgs,
    #[arg(long, default_value_t = 960)]
    width: u32,
    #[arg(long, default_value_t = 540)]
    height: u32,
    #[command(flatten)]
    set: SettingsArgs,
    #[command(flatten)]
    gpu: GpuArgs,
}

/// One frame's figures.
#[derive(serde::Serialize)]
struct FrameFigures {
    frame: Option<u64>,
    roughness: Option<quality::Roughness>,
    references: Vec<(String, quality::Comparison)>,
}

/// What `--json` holds.
#[derive(serde::Serialize)]
struct Report {
    input: String,
    device: String,
    size: [u32; 2],
    radius: f32,
    camera: String,
    surface: String,
    frames: Vec<FrameFigures>,
    /// Median over the frames of the roughness p90, degrees.
    roughness_p90_median_deg: Option<f32>,
    flicker: Option<quality::Flicker>,
    /// With --mesh: the unsmoothed and the smoothed meshes' change from frame to frame.
    mesh_flicker: Option<[(String, quality::MeshFlicker); 2]>,
}

/// A rendered frame: colour, the water's depth and its view-space normals.
pub type Rendered = (image::RgbaImage, DepthImage, Vec<[f32; 3]>);

/// The frame just rendered.
pub fn read_frame(r: &Renderer, w: u32, h: u32) -> Result<Rendered> {
    let state = r.state();
    let colour = state.read_final()?;
    let depth = state.read_f32(state.smoothed_depth().context("nothing rendered")?)?;
    let t = r.state().targets().context("nothing rendered")?;
    let words: Vec<u32> = bytemuck::pod_collect_to_vec(&state.read_image(&t.normals)?);
    let normals =
        words.into_iter().map(|w| if w == 0 { [0.0; 3] } else { meniscus::renderer::unpack_normal(w) }).collect();
    Ok((colour, DepthImage { width: w as usize, height: h as usize, depth }, normals))
}

fn figures(
    frame: Option<u64>,
    depth: &DepthImage,
    normals: &[[f32; 3]],
    refs: &[(String, DepthImage)],
    fovy: f32,
    radius: f32,
) -> Result<FrameFigures> {
    let roughness = quality::roughness(normals, depth.width, depth.height);

    let mut references = vec![];
    for (name, img) in refs {
        references.push((name.clone(), quality::compare(depth, img, fovy, radius).with_context(|| name.clone())?));
    }
    Ok(FrameFigures { frame, roughness, references })
}

fn opt(v: Option<f32>, digits: usize) -> String {
    v.map_or("–".into(), |v| format!("{v:.digits$}"))
}

pub fn run(a: &QualityArgs) -> Result<()> {
    check_size(a.width, a.height)?;
    if let Some(j) = &a.json {
        check_report("--json", j, meniscus::output::FileKind::Json)?;
    }
    if let Some(o) = &a.depth_out {
        crate::args::check_out("--depth-out", o, meniscus::output::FileKind::Npy)?;
    }
    let select = Select { range: a.frames_range.as_deref().map(FrameRange::parse).transpose()?, shard: None };
    let job = Job::open(&a.scene, &a.load, a.set.resolve()?, select)?;
    if job.frames.is_none() && a.frames_range.is_some() {
        bail!("--frames applies to a sequence");
    }
    if job.frames.is_some() && (a.depth.is_some() || a.depth_out.is_some()) {
        bail!("--depth and --depth-out measure one frame, not a sequence");
    }
    if a.mesh {
        if job.frames.is_none() || !a.reference.is_empty() || a.depth.is_some() {
            bail!("--mesh measures a sequence's meshes from frame to frame (no --reference or --depth)");
        }
        return mesh_flicker(a, &job);
    }
    let s = &job.settings;
    let view = job.view(a.width, a.height);
    let fovy = view.camera.fovy_deg;
    let surface = |p: &std::path::Path| -> Result<DepthImage> {
        if p.extension().is_some_and(|e| e.eq_ignore_ascii_case("npy")) {
            Ok(quality::read_depth_npy(p)?)
        } else {
            let mesh = meniscus::scene::geometry::Geometry::load_mesh(p)?;
            Ok(quality::mesh_depth(&mesh, &view.camera, a.width as usize, a.height as usize))
        }
    };
    let refs: Vec<(String, DepthImage)> =
        a.reference.iter().map(|p| Ok((p.display().to_string(), surface(p)?))).collect::<Result<_>>()?;
    for (name, img) in &refs {
        if (img.width, img.height) != (a.width as usize, a.height as usize) {
            bail!(
                "--reference {name}: {}×{} but the render is {}×{}: pass --width {} --height {}",
                img.width,
                img.height,
                a.width,
                a.height,
                img.width,
                img.height
            );
        }
    }
    if let Some(p) = &a.depth {
        // A given surface: no render, no device.
        let depth = surface(p)?;
        check_depth_out(a)?;
        if (depth.width, depth.height) != (a.width as usize, a.height as usize) {
            bail!(
                "--depth {}: {}×{} but --width/--height say {}×{}",
                p.display(),
                depth.width,
                depth.height,
                a.width,
                a.height
            );
        }
        let normals = quality::normals_from_depth(&depth, fovy);
        let frames = vec![figures(None, &depth, &normals, &refs, fovy, s.radius)?];
        return report(a, &job, &view, "none (a given surface)".into(), frames, None, Some(&depth));
    }
    check_depth_out(a)?;
    let gpu = a.gpu.open()?;
    let mut r = Renderer::new(&gpu)?;
    job.apply_background(&mut r)?;
    eprintln!("{}", job.summary(Some((a.width, a.height))));
    let mut frames = vec![];
    let s = &job.settings;
    let flicker = match &job.frames {
        None => {
            job.upload(&mut r, &job.first)?;
            r.render(&view, s)?;
            let (_, depth, normals) = read_frame(&r, a.width, a.height)?;
            frames.push(figures(None, &depth, &normals, &refs, fovy, s.radius)?);
            report(a, &job, &view, gpu.info.name.clone(), frames, None, Some(&depth))?;
            return finish(&gpu);
        }
        Some(list) => {
            if list.len() < 2 {
                bail!("{}: a sequence of {} frame: the flicker needs two or more", a.scene.input, list.len());
            }
            let mut tracker = job.motion();
            let mut meter = FlickerMeter::default();
            // The previous frame's images.
            let mut prev: Option<Rendered> = None;
            let dt = 1.0 / job.frame_rate();
            let bar = crate::args::progress(list.len() as u64, "frames");
            for f in list {
                let p =
                    meniscus::scene::load_with(&f.path, &job.load).with_context(|| format!("frame {}", f.number))?;
                job.upload_next(&mut r, &p, &mut tracker, None)?;
                r.render(&view, s)?;
                let now = read_frame(&r, a.width, a.height)?;
                frames.push(figures(Some(f.number), &now.1, &now.2, &refs, fovy, s.radius)?);
                // Velocities: the file's, else the tracker's from the positions' change (by id, else by index).
                if let Some(before) = &prev {
                    let motion = tracker.velocities().map(|v| SurfaceMotion {
                        positions: &p.positions,
                        velocities: v,
                        dt,
                        camera: &view.camera,
                        radius: s.radius,
                    });
                    meter.add(
                        &Picture { colour: &before.0, depth: &before.1, normals: &before.2 },
                        &Picture { colour: &now.0, depth: &now.1, normals: &now.2 },
                        motion.as_ref(),
                    );
                }
                prev = Some(now);
                bar.inc(1);
            }
            bar.finish_and_clear();
            Some(meter.result())
        }
    };
    report(a, &job, &view, gpu.info.name.clone(), frames, flicker, None)?;
    finish(&gpu)
}

/// `--depth-out` again once every input is read (the references, `--depth`): never over one of them, refused
/// before the work rather than at the write.
fn check_depth_out(a: &QualityArgs) -> Result<()> {
    if let Some(o) = &a.depth_out {
        crate::args::check_out("--depth-out", o, meniscus::output::FileKind::Npy)?;
    }
    Ok(())
}

/// `--mesh`: each frame meshed (unsmoothed and smoothed), each mesh against the next frame's.
fn mesh_flicker(a: &QualityArgs, job: &Job) -> Result<()> {
    use meniscus::field::{extract::ExtractParams, smooth::SmoothParams};
    let list = job.frames.as_ref().expect("a sequence");
    if list.len() < 2 {
        bail!("{}: a sequence of {} frame: the flicker needs two or more", a.scene.input, list.len());
    }
    let r = job.settings.radius;
    let dt = 1.0 / job.frame_rate();
    let kinds = [("unsmoothed", 0u32), ("smoothed (25 iterations)", 25)];
    let mut meters = [quality::MeshFlickerMeter::default(), quality::MeshFlickerMeter::default()];
    // The previous frame: its meshes' vertices, positions and velocities.
    struct Before {
        meshes: [Vec<[f32; 3]>; 2],
        positions: Vec<[f32; 3]>,
        velocities: Option<Vec<[f32; 3]>>,
    }
    let mut prev: Option<Before> = None;
    let mut tracker = job.motion();
    let bar = crate::args::progress(list.len() as u64, "frames");
    for f in list {
        let p = meniscus::scene::load_with(&f.path, &job.load).with_context(|| format!("frame {}", f.number))?;
        // Velocities: the file's, else the tracker's from the positions' change (by id, else by index).
        tracker.next(&p);
        let vel = tracker.velocities().map(<[_]>::to_vec);
        let mut meshes: [Vec<[f32; 3]>; 2] = Default::default();
        for (k, (_, iterations)) in kinds.iter().enumerate() {
            let recon = meniscus::surface::mesh::Reconstruct {
                support: 4.0 * r,
                extract: ExtractParams::new(0.5 * r, 0.6),
                smoothing: SmoothParams { iterations: *iterations, ..Default::default() },
            };
            let rec = meniscus::surface::mesh::reconstruct_field(&p.positions, &recon, None)
                .with_context(|| format!("frame {}: the mesh", f.number))?;
            meshes[k] = rec.mesh.vertices;
        }
        if let Some(b) = &prev {
            let motion =
                b.velocities.as_deref().map(|v| quality::FrameMotion { positions: &b.positions, velocities: v, dt });
            for (k, meter) in meters.iter_mut().enumerate() {
                meter.add(&b.meshes[k], &meshes[k], r, motion.as_ref());
            }
        }
        prev = Some(Before { meshes, positions: p.positions, velocities: vel });
        bar.inc(1);
    }
    bar.finish_and_clear();
    let result = [(kinds[0].0.to_string(), meters[0].result()), (kinds[1].0.to_string(), meters[1].result())];
    println!(
        "{}: meshes (cube 0.5 r) from frame to frame, particle radii (capped at {} r)",
        a.scene.input,
        quality::MESH_REACH
    );
    println!("\n| mesh | pairs | mean | p90 | moved with the flow: mean | p90 |\n|---|---:|---:|---:|---:|---:|");
    for (name, m) in &result {
        println!(
            "| {name} | {} | {:.3} | {:.3} | {} | {} |",
            m.pairs,
            m.plain_mean_r,
            m.plain_p90_r,
            opt(m.warped_mean_r, 3),
            opt(m.warped_p90_r, 3)
        );
    }
    if let Some(j) = &a.json {
        let report = Report {
            input: a.scene.input.clone(),
            device: "none (CPU meshes)".into(),
            size: [a.width, a.height],
            radius: r,
            camera: String::new(),
            surface: "mesh".into(),
            frames: vec![],
            roughness_p90_median_deg: None,
            flicker: None,
            mesh_flicker: Some(result),
        };
        meniscus::output::write_json(j, &report)?;
        eprintln!("wrote {}", j.display());
    }
    Ok(())
}

/// Print the figures, and write `--json` and `--depth-out`.
fn report(
    a: &QualityArgs,
    job: &Job,
    view: &meniscus::view::View,
    device: String,
    frames: Vec<FrameFigures>,
    flicker: Option<quality::Flicker>,
    depth: Option<&DepthImage>,
) -> Result<()> {
    let s = &job.settings;
    let mut p90s: Vec<f64> = frames.iter().filter_map(|f| f.roughness.map(|r| r.p90_deg as f64)).collect();
    let report = Report {
        input: a.scene.input.clone(),
        device,
        size: [a.width, a.height],
        radius: s.radius,
        camera: view.camera.to_arg(),
        surface: s.surface.name().to_string(),
        roughness_p90_median_deg: quality::quantile(&mut p90s, 0.5),
        frames,
        flicker,
        mesh_flicker: None,
    };
    print_report(&report);
    if let Some(j) = &a.json {
        meniscus::output::write_json(j, &report)?;
        eprintln!("wrote {}", j.display());
    }
    if let (Some(o), Some(d)) = (&a.depth_out, depth) {
        meniscus::output::write_npy(o, &[d.height, d.width], &d.depth)?;
        eprintln!("wrote {}", o.display());
    }
    Ok(())
}

fn print_report(r: &Report) {
    println!("{} on {}, {}×{}, radius {}, surface {}", r.input, r.device, r.size[0], r.size[1], r.radius, r.surface);
    println!("camera: --camera {}", r.camera);
    println!("\n| frame | roughness median (°) | roughness p90 (°) |\n|---|---:|---:|");
    for f in &r.frames {
        let n = f.frame.map_or("–".into(), |n| n.to_string());
        println!(
            "| {n} | {} | {} |",
            opt(f.roughness.map(|x| x.median_deg), 2),
            opt(f.roughness.map(|x| x.p90_deg), 2)
        );
    }
    if r.frames.iter().any(|f| !f.references.is_empty()) {
        println!(
            "\n| frame | reference | IoU | depth median (r) | depth p90 (r) | normal median (°) | normal p90 (°) |\n\
             |---|---|---:|---:|---:|---:|---:|"
        );
        for f in &r.frames {
            for (name, c) in &f.references {
                println!(
                    "| {} | {name} | {:.3} | {} | {} | {} | {} |",
                    f.frame.map_or("–".into(), |n| n.to_string()),
                    c.iou,
                    opt(c.depth_median_r, 2),
                    opt(c.depth_p90_r, 2),
                    opt(c.normal_median_deg, 1),
                    opt(c.normal_p90_deg, 1)
                );
            }
        }
    }
    if let Some(f) = &r.flicker {
        println!(
            "\nflicker over {} frame pairs: colour {:.3} steps of 255 per channel on average (p99 of a pixel's \
             largest channel {:.1}), normals {:.3}° on average (p90 {:.3}°), the normals' warping error {}° ({} of the \
             water's pixels warped); the particles move {} radii a frame (median)",
            f.pairs,
            f.colour_mean,
            f.colour_p99,
            f.normal_mean_deg,
            f.normal_p90_deg,
            opt(f.warp_mean_deg, 3),
            f.warp_coverage.map_or("–".into(), |c| format!("{:.0} %", 100.0 * c)),
            opt(f.particle_step_median_r, 3)
        );
    }
}
