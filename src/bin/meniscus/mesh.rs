//! `meniscus mesh`: extract the SPH iso-surface of a particle file (or of every frame of a sequence) as a
//! triangle mesh — marching cubes over the colour field the `iso` pass ray-casts (`meniscus::field::extract`) — and
//! write it as PLY, OBJ or VTK. On the CPU (rayon; `--threads` changes nothing but the time) or, with `--gpu`, on
//! the GPU (the `mc` pass, src/compute/mc.rs: the same mesh up to float rounding).

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::Args;

use meniscus::field::extract::ExtractParams;
use meniscus::scene::sequence::{FrameRange, Prefetch};
use meniscus::scene::{self, Particles};
use meniscus::surface::mesh::ExtractionStats;

use meniscus::export::usd::{PointsFrame, UsdWriter};
use meniscus::export::vdb;
use meniscus::output::FileKind;
use meniscus::surface::mesh::Reconstructed;

use crate::args::{check_out, out_kind, LoadArgs, SceneArgs};
use crate::job::{Job, Select};

/// `meniscus mesh`.
/// Most worker threads `--threads` asks for (each is an OS thread with its own stack and block buffers).
pub const MAX_THREADS: usize = 1024;

#[derive(Args, Clone, Debug)]
pub struct MeshArgs {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    load: LoadArgs,
    /// Output: a mesh, .ply (binary, with normals), .obj or .vtk (legacy binary POLYDATA, with normals); a USD
    /// stage, .usd or .usdc (binary) or .usda (text), a sequence's frames as time samples of one mesh with
    /// per-vertex velocities for motion blur; or an OpenVDB level set, .vdb (the field's narrow band on the marching-cubes lattice).
    /// For a sequence of .ply/.obj/.vtk/.vdb, {} in the name is the frame number (4 digits), else _NNNN is
    /// added before the extension. Default: mesh.ply (none with --compare alone).
    #[arg(short, long)]
    out: Option<PathBuf>,
    /// Sequence: frames FIRST..LAST[:STEP] (inclusive, by the numbers in the file names), e.g. 10..40:2.
    #[arg(long = "frames", value_name = "RANGE")]
    frames_range: Option<String>,
    /// Write the thesis' comparison of the two techniques: one PNG with the screen-space surface (default
    /// settings), the iso-surface ray cast and the extracted mesh (same shading) side by side, each labelled
    /// with its time — GPU ms per frame, plus the CPU extraction for the mesh (and its smoothing with
    /// --smoothing-iters). One input file; --camera or fitted.
    #[arg(long, value_name = "PNG")]
    compare: Option<PathBuf>,
    /// Width of each --compare panel (default 640).
    #[arg(long)]
    width: Option<u32>,
    /// Height of each --compare panel (default 360).
    #[arg(long)]
    height: Option<u32>,
    #[command(flatten)]
    device: crate::args::GpuArgs,
    /// Marching-cubes edge length in particle radii (splashsurf's --cube-size).
    #[arg(long, value_parser = crate::args::finite::<f32>, allow_negative_numbers = true, default_value_t = 0.5)]
    cube_size: f32,
    /// Kernel support in particle radii (splashsurf: 2 × smoothing length 2 = 4).
    #[arg(long, value_parser = crate::args::finite::<f32>, allow_negative_numbers = true, default_value_t = 4.0)]
    support: f32,
    /// Iso value (default: 0.6 for the SPH field, splashsurf's; for the metaball field the value that puts an
    /// isolated particle's surface at its radius).
    #[arg(long, value_parser = crate::args::finite::<f32>, allow_negative_numbers = true)]
    threshold: Option<f32>,
    /// The field: sph (the colour field the iso pass ray-casts and splashsurf meshes) or metaball (the thesis'
    /// f(d) = (d/(√2 R_c))⁴ − (d/(√2 R_c))² + ¼ within R_c, unnormalised).
    #[arg(long, value_parser = ["sph", "metaball"], default_value = "sph")]
    field: String,
    /// The metaball field's radius of influence R_c in particle radii (default 3).
    #[arg(long, value_parser = crate::args::finite::<f32>, allow_negative_numbers = true)]
    rc: Option<f32>,
    /// Cubes per block edge: each block scatters its particles into its own corner values and marches its
    /// cubes, in parallel. Default: chosen from the particles and the cube size, never from the threads (64 where
    /// that leaves at least 64 occupied blocks, else 32), so the default writes the same bytes on any machine and
    /// at any --threads. 0: the per-corner paths (every corner gathers its particles), surface following unless
    /// --dense. The mesh is the same at every block size up to the order of its vertices and triangles.
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=1024))]
    block: Option<u32>,
    /// With --block 0: evaluate the field at every cube corner within the kernel support (the reference)
    /// instead of following the surface in from the outside (which skips closed cavities inside the fluid).
    #[arg(long)]
    dense: bool,
    /// Laplacian smoothing iterations after extraction (splashsurf's finishing, e.g. 25; src/field/smooth.rs).
    #[arg(long, default_value_t = 0)]
    smoothing_iters: u32,
    /// With --smoothing-iters: every vertex moves fully (no feature weights; isolated droplets shrink).
    #[arg(long)]
    no_smoothing_weights: bool,
    /// Worker threads (default: all cores); changes nothing but the time.
    #[arg(long)]
    threads: Option<usize>,
    /// Extract on the GPU (the `mc` pass: field on the occupied blocks, count, prefix sum, emit; the host
    /// welds the vertices): the same lattice and field as the CPU path, the same mesh up to float rounding.
    /// Prints the GPU ms of each stage.
    #[arg(long)]
    gpu: bool,
    /// USD: frames per second (time codes are frame numbers). Default: the sequence's scene.json, else 25.
    #[arg(long, value_parser = crate::args::finite::<f64>, allow_negative_numbers = true)]
    fps: Option<f64>,
    /// USD: the stage's metersPerUnit (default 1: SPlisHSPlasH's scenes are in metres).
    #[arg(long, value_parser = crate::args::finite::<f64>, allow_negative_numbers = true)]
    meters_per_unit: Option<f64>,
    /// USD, sequences: add the diffuse particles (spray, foam, bubbles; `[diffuse]` of --settings) as a
    /// UsdGeomPoints with widths, velocities and a `kind` primvar (0 foam, 1 spray, 2 bubbles).
    #[arg(long, alias = "foam")]
    diffuse: bool,
    /// VDB: also write the field as a fog volume (grid `density`, clamped to [0, 1]).
    #[arg(long)]
    vdb_fog: bool,
    /// VDB: the level set's half-width in voxels (default: 3, OpenVDB's).
    #[arg(long, value_parser = crate::args::finite::<f32>, allow_negative_numbers = true)]
    vdb_half_width: Option<f32>,
}

/// Run the extraction.
pub fn run(a: &MeshArgs) -> Result<()> {
    let Checked { out_kind, metaball, rc, threshold, meters_per_unit, vdb_half_width } = check_args(a)?;
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(n) = a.threads {
        if !(1..=MAX_THREADS).contains(&n) {
            bail!("--threads {n}: between 1 and {MAX_THREADS}");
        }
        pool = pool.num_threads(n);
    }
    let pool = pool.build()?;
    let select = Select { range: a.frames_range.as_deref().map(FrameRange::parse).transpose()?, shard: None };
    let job = Job::open(&a.scene, &a.load, meniscus::settings::Settings::default(), select)?;
    eprintln!("{}", job.summary(a.compare.as_ref().map(|_| compare_size(a))));
    // Again now that the inputs are known (the job records every file it reads).
    if let Some(p) = &a.compare {
        check_out("--compare", p, FileKind::Png)?;
    }
    if let Some(png) = &a.compare {
        if job.frames.is_some() {
            bail!("--compare takes one file, not a sequence");
        }
        let (w, h) = compare_size(a);
        crate::args::check_size(w, h)?;
        compare(a, &job, png)?;
        if a.out.is_none() {
            return Ok(());
        }
    }
    let out = a.out.clone().unwrap_or_else(|| PathBuf::from("mesh.ply"));
    if job.frames.is_none() {
        check_out("--out", &out, out_kind)?;
    }
    let r = job.settings.radius;
    let block = a.block.unwrap_or(meniscus::field::extract::AUTO_BLOCK);
    let params = ExtractParams { cube: a.cube_size * r, threshold, dense: a.dense, block, metaball };
    let support = if metaball { rc } else { a.support };
    let gpu_mc = if a.gpu {
        let gpu = a.device.open()?;
        let mc = meniscus::compute::mc::Mc::new(&gpu)?;
        Some((gpu, mc))
    } else {
        None
    };
    // Extract one frame: the mesh with its field, and a line saying where the time went.
    let extract = |p: &Particles| extract_frame(a, &pool, p, (support * r, params), gpu_mc.as_ref());
    let vdb = |rec: &Reconstructed, out: &PathBuf| -> Result<()> {
        pool.install(|| vdb::write_surface(out, rec, vdb_half_width, a.vdb_fog))?;
        Ok(())
    };
    let mut usd = match out_kind {
        FileKind::Usd => {
            let fps = a.fps.unwrap_or(job.frame_rate() as f64);
            let comment = format!("meniscus mesh {} (cube {} r, support {} r)", job.label, a.cube_size, support);
            Some(UsdWriter::create(&out, fps, meters_per_unit, a.diffuse, &comment)?)
        }
        _ => None,
    };
    if a.diffuse && job.frames.is_none() {
        bail!("--diffuse generates diffuse particles from a sequence (a pattern with {{}}, a folder or a glob)");
    }
    let mut walk = if a.diffuse { Some(crate::diffuse::Walk::new(&job)?) } else { None };
    let mut no_velocities = false;
    let per_frame_files = usd.is_none();
    // Write one frame's mesh (a stage's time sample, a VDB or a mesh file); returns where it went.
    let mut write = |rec: &Reconstructed, p: &Particles, number: u64, out: &PathBuf| -> Result<String> {
        match usd.as_mut() {
            Some(w) => write_usd_frame(w, (rec, p, number), &pool, &job, walk.as_mut(), &mut no_velocities, out),
            None if out_kind == FileKind::Vdb => {
                vdb(rec, out)?;
                Ok(out.display().to_string())
            }
            None => {
                meniscus::output::write_mesh(out, rec.mesh.data())?;
                Ok(out.display().to_string())
            }
        }
    };
    // One frame's line: what went in and out, where the time went.
    let line = |p: &Particles, (rec, how, secs): &(Reconstructed, String, f64), write_s: f64, shown: &str| {
        let m = &rec.mesh;
        format!(
            "{} particles → {} vertices, {} triangles in {secs:.2} s {how}, written in {write_s:.3} s → {shown}",
            p.len(),
            m.vertices.len(),
            m.triangles.len(),
        )
    };
    // Validation messages (--validation) fail the run at its end.
    let done = || gpu_mc.as_ref().map_or(Ok(()), |(gpu, _)| crate::args::finish(gpu));
    let Some(frames) = job.frames.clone() else {
        // One file: one time sample, at 0.
        let done_frame = extract(&job.first).with_context(|| job.label.clone())?;
        let t_write = std::time::Instant::now();
        let shown = write(&done_frame.0, &job.first, 0, &out).with_context(|| job.label.clone())?;
        eprintln!("{}", line(&job.first, &done_frame, t_write.elapsed().as_secs_f64(), &shown));
        if let Some(w) = usd {
            w.finish()?;
        }
        return done();
    };
    let names = crate::args::Numbered::new(&out, out_kind.extensions()[0]);
    if per_frame_files {
        for f in &frames {
            check_out("--out", &names.path(f.number), out_kind)?;
        }
    }
    let bar = crate::args::progress(frames.len() as u64, "meshes");
    // A pipeline of three: the prefetch thread loads frame k + 1 while this one extracts frame k (on the CPU's
    // threads or the device) and the writer writes frame k − 1.
    let t0 = std::time::Instant::now();
    let last = std::thread::scope(|sc| -> Result<String> {
        type Done = (Particles, (Reconstructed, String, f64), u64, PathBuf, PathBuf);
        let (tx, rx) = std::sync::mpsc::sync_channel::<Done>(1);
        let bar = &bar;
        let writer = sc.spawn(move || -> Result<String> {
            let mut last = String::new();
            for (p, done, number, path, source) in rx {
                let t_write = std::time::Instant::now();
                let shown = write(&done.0, &p, number, &path).with_context(|| source.display().to_string())?;
                last = line(&p, &done, t_write.elapsed().as_secs_f64(), &shown);
                bar.set_message(last.clone());
                bar.inc(1);
            }
            Ok(last)
        });
        for (frame, loaded) in Prefetch::start(frames.clone(), job.load.clone(), 2) {
            let (p, ()): (scene::Particles, ()) = loaded?;
            let path = if out_kind == FileKind::Usd { out.clone() } else { names.path(frame.number) };
            let done = extract(&p).with_context(|| frame.path.display().to_string())?;
            // A writer that stopped has an error to say: it is joined below.
            if tx.send((p, done, frame.number, path, frame.path.clone())).is_err() {
                break;
            }
        }
        drop(tx);
        writer.join().map_err(|_| anyhow::anyhow!("the mesh writer panicked"))?
    })?;
    bar.finish();
    if let Some(w) = usd {
        let t = std::time::Instant::now();
        w.finish()?;
        eprintln!("{}: {} time samples assembled in {:.2} s", out.display(), frames.len(), t.elapsed().as_secs_f64());
    }
    // The bar is hidden when stderr is not a terminal: say what was done either way.
    eprintln!("{} meshes in {:.1} s; the last: {last}", frames.len(), t0.elapsed().as_secs_f64());
    done()
}

/// One frame's mesh with its field (`support` in world units, the lattice `params`; on the device with
/// `gpu_mc`), a line saying where the time went, and the seconds it took.
fn extract_frame(
    a: &MeshArgs,
    pool: &rayon::ThreadPool,
    p: &Particles,
    (support, params): (f32, ExtractParams),
    gpu_mc: Option<&(std::sync::Arc<meniscus::device::Gpu>, meniscus::compute::mc::Mc)>,
) -> Result<(Reconstructed, String, f64)> {
    let t0 = std::time::Instant::now();
    let (m, how) = pool.install(|| -> Result<_> {
        let recon = meniscus::surface::mesh::Reconstruct {
            support,
            extract: params,
            smoothing: meniscus::field::smooth::SmoothParams {
                iterations: a.smoothing_iters,
                weights: !a.no_smoothing_weights,
                ..Default::default()
            },
        };
        let rec = meniscus::surface::mesh::reconstruct_field(&p.positions, &recon, gpu_mc.map(|(g, mc)| (g, mc)))
            .with_context(|| {
                if a.gpu {
                    format!(
                        "mesh --gpu at --cube-size {} (radii): try a larger --cube-size, or the CPU path \
                             (without --gpu)",
                        a.cube_size
                    )
                } else {
                    format!("mesh at --cube-size {} (radii)", a.cube_size)
                }
            })?;
        let rep = &rec.report;
        // The one stray-particle policy: particles far from the fluid are left out, and counted.
        if rep.strays > 0 {
            eprintln!("{}", scene::stray_warning(rep.strays, "the mesh"));
        }
        let gpu_name = gpu_mc.map_or("", |(g, _)| g.info.name.as_str());
        let how = describe(rep, gpu_name, pool.current_num_threads(), recon.smoothing.iterations);
        Ok((rec, how))
    })?;
    Ok((m, how, t0.elapsed().as_secs_f64()))
}

/// One frame of a USD stage: the mesh at time `number` with its vertex velocities (zero, said once through
/// `warned`, when the particles have none), and the diffuse particles the walk gives (`--diffuse`).
fn write_usd_frame(
    w: &mut UsdWriter,
    (rec, p, number): (&Reconstructed, &Particles, u64),
    pool: &rayon::ThreadPool,
    job: &Job,
    walk: Option<&mut crate::diffuse::Walk>,
    warned: &mut bool,
    out: &std::path::Path,
) -> Result<String> {
    let m = &rec.mesh;
    let t_vel = std::time::Instant::now();
    let vel = match &p.velocities {
        Some(v) => pool.install(|| rec.at_vertices(v)),
        None => {
            if !*warned {
                eprintln!("warning: {} has no velocities: the stage's velocities are zero (no motion blur)", job.label);
                *warned = true;
            }
            vec![[0.0; 3]; m.vertices.len()]
        }
    };
    let vel_s = t_vel.elapsed().as_secs_f64();
    pool.install(|| w.add_mesh(number as f64, &m.vertices, &m.normals, &m.triangles, &vel))?;
    if let Some(walk) = walk {
        let ps = walk.advance(number, Some(p))?;
        let size = job.settings.diffuse.size * job.settings.radius * 2.0;
        let pos: Vec<[f32; 3]> = ps.iter().map(|d| d.position.to_array()).collect();
        let vel: Vec<[f32; 3]> = ps.iter().map(|d| d.velocity.to_array()).collect();
        let widths = vec![size; ps.len()];
        let kinds: Vec<i32> = ps.iter().map(|d| d.kind as i32).collect();
        let frame = PointsFrame { positions: &pos, velocities: &vel, widths: &widths, kinds: &kinds };
        w.add_points(number as f64, &frame)?;
    }
    Ok(format!("{} (time {number}; vertex velocities {vel_s:.3} s)", out.display()))
}

/// Where one frame's extraction spent its time, as the progress line says it.
fn describe(
    rep: &meniscus::surface::mesh::ReconstructReport,
    gpu_name: &str,
    threads: usize,
    smoothing: u32,
) -> String {
    let t_field = rep.field_s;
    let how = match &rep.extraction {
        ExtractionStats::Gpu(st) => {
            let stages: Vec<String> = st.gpu.0.iter().map(|(n, t)| format!("{n} {t:.2}")).collect();
            format!(
                "on {gpu_name} ({} blocks; host: grid and 1/n {t_field:.3} s, blocks {:.1} ms, upload {:.1} ms; GPU \
                 {:.2} ms: {}; copy of the indexed mesh {:.1} ms)",
                st.blocks,
                st.host_setup_ms,
                st.host_upload_ms,
                st.gpu_ms(),
                stages.join(", "),
                st.host_copy_ms
            )
        }
        // Where the time goes: scatter and march are summed over the threads.
        ExtractionStats::Cpu(Some(t)) => format!(
            "({threads} threads; grid and 1/n {t_field:.3} s, {} blocks of {}³ cubes: scatter {:.3} s, march {:.3} s \
             (thread time), weld {:.3} s)",
            t.blocks, t.block, t.scatter, t.march, t.weld
        ),
        ExtractionStats::Cpu(None) => format!("({threads} threads; grid and 1/n {t_field:.3} s)"),
    };
    if smoothing > 0 {
        format!("{how}, smoothed ({smoothing} iterations) in {:.3} s", rep.smooth_s)
    } else {
        how
    }
}

/// What `check_args` derives from the flags once they are known to fit together.
struct Checked {
    out_kind: FileKind,
    metaball: bool,
    rc: f32,
    threshold: f32,
    meters_per_unit: f64,
    vdb_half_width: f32,
}

/// Every flag in its range and in its context (a flag of another output or field is refused, not ignored),
/// outputs checked first: a misplaced argument (`--compare FILE.bgeo`) must not cost the user a file.
fn check_args(a: &MeshArgs) -> Result<Checked> {
    if let Some(p) = &a.compare {
        check_out("--compare", p, FileKind::Png)?;
    }
    let out_kind = match &a.out {
        Some(p) => out_kind("--out", p, &meniscus::output::SURFACE_KINDS)?,
        None => FileKind::Ply,
    };
    if !(a.cube_size.is_finite() && a.cube_size > 0.05 && a.cube_size <= 8.0) {
        bail!("--cube-size must be in (0.05, 8] particle radii");
    }
    if !(a.support.is_finite() && (1.0..=16.0).contains(&a.support)) {
        bail!("--support must be in [1, 16] particle radii");
    }
    if a.smoothing_iters > 1000 {
        bail!("--smoothing-iters must be at most 1000");
    }
    let metaball = a.field == "metaball";
    if a.rc.is_some() && !metaball {
        bail!("--rc applies to --field metaball");
    }
    let rc = a.rc.unwrap_or(3.0);
    if metaball && !(1.0..=16.0).contains(&rc) {
        bail!("--rc must be in [1, 16] particle radii");
    }
    if a.compare.is_none() && (a.width.is_some() || a.height.is_some()) {
        bail!("--width and --height size the --compare panels");
    }
    let threshold =
        a.threshold.unwrap_or(if metaball { meniscus::field::extract::metaball_threshold(1.0, rc) } else { 0.6 });
    let top = if metaball { 0.25 } else { 1.0 };
    if !(threshold > 0.0 && threshold < top) {
        bail!("--threshold must be in (0, {top}) for the {} field", a.field);
    }
    if out_kind != FileKind::Usd && (a.fps.is_some() || a.diffuse) {
        bail!("--fps and --diffuse apply to a USD stage (--out NAME.usd)");
    }
    if out_kind != FileKind::Usd && a.meters_per_unit.is_some() {
        bail!("--meters-per-unit applies to a USD stage (--out NAME.usd)");
    }
    if out_kind != FileKind::Vdb && (a.vdb_fog || a.vdb_half_width.is_some()) {
        bail!("--vdb-fog and --vdb-half-width apply to --out NAME.vdb");
    }
    let meters_per_unit = a.meters_per_unit.unwrap_or(1.0);
    let vdb_half_width = a.vdb_half_width.unwrap_or(3.0);
    if let Some(f) = a.fps {
        if !(f.is_finite() && f > 0.0 && f <= 10000.0) {
            bail!("--fps must be in (0, 10000]");
        }
    }
    if !(meters_per_unit.is_finite() && meters_per_unit > 0.0) {
        bail!("--meters-per-unit must be positive");
    }
    if out_kind == FileKind::Vdb {
        if metaball {
            bail!("--out .vdb writes the SPH field's level set; drop --field metaball");
        }
        if a.smoothing_iters > 0 {
            bail!("--out .vdb writes the field's level set, which --smoothing-iters (a mesh operation) does not change; drop it");
        }
        if !(vdb_half_width.is_finite() && (1.0..=32.0).contains(&vdb_half_width)) {
            bail!("--vdb-half-width must be in [1, 32] voxels");
        }
    }
    if a.compare.is_some() && metaball {
        bail!("--compare renders the SPH field (the one the iso pass ray-casts); drop --field metaball");
    }
    Ok(Checked { out_kind, metaball, rc, threshold, meters_per_unit, vdb_half_width })
}

/// The size of each `--compare` panel.
fn compare_size(a: &MeshArgs) -> (u32, u32) {
    (a.width.unwrap_or(640), a.height.unwrap_or(360))
}

/// `--compare`: render the job's particles with the three surfaces at one camera, time each (GPU medians of 3
/// frames after one warm-up; the mesh adds its CPU extraction), label and place them side by side.
fn compare(a: &MeshArgs, job: &Job, png: &std::path::Path) -> Result<()> {
    use meniscus::settings::{Settings, Surface};
    let gpu = a.device.open()?;
    let mut r = meniscus::renderer::Renderer::new(&gpu)?;
    job.apply_background(&mut r)?;
    job.upload(&mut r, &job.first)?;
    let (w, h) = compare_size(a);
    let view = job.view(w, h);
    let mut out = image::RgbaImage::new(3 * w, h);
    let base = job.settings.clone();
    let panels: [(&str, Settings); 3] = [
        ("screen space (spheres + narrow-range)", base.clone()),
        ("iso-surface ray cast", {
            let mut s = Settings::preset("quality")?;
            s.radius = base.radius;
            s
        }),
        (if a.smoothing_iters > 0 { "marching-cubes mesh, smoothed" } else { "marching-cubes mesh" }, {
            let mut s = Settings::preset("quality")?;
            s.radius = base.radius;
            s.surface = Surface::Mesh;
            s.mesh.cube = a.cube_size;
            s.mesh.smoothing_iters = a.smoothing_iters;
            s.mesh.smoothing_weights = !a.no_smoothing_weights;
            s.iso.support = a.support;
            s.iso.threshold = a.threshold.unwrap_or(0.6);
            s
        }),
    ];
    for (k, (name, s)) in panels.iter().enumerate() {
        r.render(&view, s)?;
        let mut ms: Vec<f64> = (0..3).map(|_| r.render(&view, s).map(|t| t.total())).collect::<Result<_, _>>()?;
        let gpu_ms = meniscus::timing::median(&mut ms);
        let label = match (
            s.surface,
            r.state().surfaces().technique::<meniscus::surface::mesh::FluidMesh>().and_then(|m| m.mesh_stats()),
        ) {
            (Surface::Mesh, Some((secs, _, tris))) => {
                let cpu = if s.mesh.smoothing_iters > 0 {
                    "CPU extraction + smoothing + BVH"
                } else {
                    "CPU extraction + BVH"
                };
                format!("{:.0} ms {cpu} ({tris} triangles) + {gpu_ms:.1} ms GPU", secs * 1e3)
            }
            _ => format!("{gpu_ms:.1} ms GPU"),
        };
        eprintln!("{name}: {label}");
        let img = r.state().read_final()?;
        image::imageops::overlay(&mut out, &img, (k as u32 * w) as i64, 0);
        let text = crate::demo::overlay::rasterize(&[name.to_string(), label], false, 1);
        let text = image::imageops::crop_imm(&text, 0, 0, text.width().min(w), text.height().min(h)).to_image();
        image::imageops::overlay(&mut out, &text, (k as u32 * w) as i64, 0);
    }
    meniscus::output::write_png(png, &out)?;
    eprintln!("wrote {}", png.display());
    crate::args::finish(&gpu)
}
