//! `meniscus render`: one frame headless to a PNG (with `--timings` and `--dump`), or a sequence to numbered
//! PNGs with a progress bar. Everything before the GPU is the shared [`Job`].

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::Args;

use meniscus::renderer::{Backdrop, FrameRequest, Renderer, Upload};
use meniscus::scene::sequence::{self, FrameRange, Prefetch};
use meniscus::view::View;

use meniscus::output::FileKind;

use crate::args::{check_out, check_size, finish, single_out, GpuArgs, LoadArgs, Numbered, SceneArgs, SettingsArgs};
use crate::job::{Job, Select};
use crate::movie::MOVIE_KINDS;

/// `meniscus render`.
#[derive(Args, Clone, Debug)]
pub struct RenderArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Output PNG (written atomically: no half-written file on failure; never over an input or a file of
    /// another kind). For a sequence, {} in the name is the frame number (4 digits); a folder (`frames/`) gets
    /// frame_NNNN.png inside; else _NNNN is added before the extension. A sequence to .mp4, .webm or .gif is
    /// encoded as a movie by ffmpeg while it renders (--fps, --crf, --ffmpeg-args).
    #[arg(short, long, default_value = "frame.png")]
    out: PathBuf,
    #[command(flatten)]
    movie: crate::movie::MovieArgs,
    /// Sequence: skip the frames whose output already exists (outputs are written whole or not at all, so an
    /// interrupted run resumes where it stopped); the frames rendered are byte-identical either way.
    #[arg(long)]
    resume: bool,
    /// Sequence: a frame that cannot be read is reported and skipped instead of ending the run (the count of
    /// skipped frames is printed at the end, and the exit status is 1 if any was skipped).
    #[arg(long)]
    skip_bad_frames: bool,
    /// Sequence: frames FIRST..LAST[:STEP] (inclusive, by the numbers in the file names), e.g. 10..40:2.
    #[arg(long = "frames", value_name = "RANGE")]
    frames_range: Option<String>,
    /// Sequence: render only shard K of N (every Nth frame starting with the Kth), e.g. 2/8.
    #[arg(long)]
    shard: Option<String>,
    /// Sequence: draw spray, foam and air bubbles (`[diffuse]` in a settings file): generated from the
    /// sequence in time order from its first frame (`--diffuse`), or read from an exported set (`--diffuse
    /// 'foam/f_{}.bgeo'`, as `meniscus diffuse --export` writes it).
    #[arg(long, alias = "foam", value_name = "PATTERN", num_args = 0..=1, default_missing_value = "")]
    diffuse: Option<String>,
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
    /// With --timings: frames rendered first and not timed (lavapipe compiles pipelines at first use; default 2).
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=10_000))]
    warmup: Option<u32>,
    /// With --timings: frames timed; the table shows per-pass medians (default 5).
    #[arg(long = "timed-frames", value_parser = clap::value_parser!(u32).range(1..=100_000))]
    frames: Option<u32>,
    /// Write buffers next to the PNG: depth, smoothed, thickness as OUT.NAME.npy (float32, H×W, +inf = none),
    /// normals as OUT.normals.npy (H×W×3, view space) and OUT.normals.png, ssr as OUT.ssr.png, final = the PNG.
    #[arg(long, value_delimiter = ',')]
    dump: Vec<String>,
    /// Sequence: frames on the GPU at once (1: each frame waits for the one before; 2 overlaps the next
    /// frame's upload and recording with the GPU work).
    #[arg(long, default_value_t = meniscus::renderer::FRAMES_IN_FLIGHT as u64, value_parser = clap::value_parser!(u64).range(1..=4))]
    frames_in_flight: u64,
    #[command(flatten)]
    gpu: GpuArgs,
}

/// `meniscus render`: one frame, or every frame of a sequence.
pub fn run(a: &RenderArgs) -> Result<()> {
    check_size(a.width, a.height)?;
    if !a.timings && (a.warmup.is_some() || a.frames.is_some()) {
        bail!("--warmup and --timed-frames apply to --timings");
    }
    check_dumps(a)?;
    let select = Select {
        range: a.frames_range.as_deref().map(FrameRange::parse).transpose()?,
        shard: a.shard.as_deref().map(sequence::parse_shard).transpose()?,
    };
    let job = Job::open(&a.scene, &a.load, a.set.resolve()?, select)?;
    if job.frames.is_some() {
        return render_sequence(a, &job);
    }
    if a.resume || a.skip_bad_frames || a.diffuse.is_some() {
        bail!("--resume, --skip-bad-frames and --diffuse apply to sequences");
    }
    refuse_movie_flags(a)?;
    if FileKind::by_extension(&a.out, &MOVIE_KINDS).is_ok() {
        bail!("--out {}: a movie is made from a sequence (a pattern with {{}}, a folder or a glob)", a.out.display());
    }
    let out = single_out(&a.out, "frame.png");
    check_out("--out", &out, FileKind::Png)?;
    for (d, path) in dump_paths(a, &out) {
        check_out(&format!("--dump {d}"), &path, FileKind::by_extension(&path, &[FileKind::Npy, FileKind::Png])?)?;
    }
    let sky = a.skybox.as_deref().map(meniscus::scene::sky::load_faces).transpose()?;
    let s = &job.settings;
    let mut view = job.view(a.width, a.height);
    // A frame of an export draws the simulation's spheres where they were at its number (else frame 1's).
    job.place_bodies(
        &mut view,
        meniscus::scene::sequence::number_of(std::path::Path::new(&a.scene.input)).unwrap_or(1),
    );
    let gpu = a.gpu.open()?;
    let mut r = Renderer::new(&gpu)?;
    job.apply_background(&mut r)?;
    if let Some((size, faces)) = &sky {
        r.set_background(Backdrop::Sky { size: *size, faces })?;
        view.env.sky_cube = true;
    }
    *r.parts_mut().keep_raw_depth = a.dump.iter().any(|d| d == "depth");
    job.upload(&mut r, &job.first)?;
    eprintln!("{}", job.summary(Some((a.width, a.height))));
    // Timed frames re-render the static background too, so the table shows every pass.
    r.parts_mut().background.always_render = a.timings;
    let mut times = r.render(&view, s)?;
    crate::job::warn_strays(&r, s, &mut None);
    crate::job::say_mesh_path(&r, s, &mut None);
    let first = times.clone();
    if a.timings {
        let mut runs = vec![];
        let (warmup, timed) = (a.warmup.unwrap_or(2), a.frames.unwrap_or(5));
        for k in 0..warmup + timed {
            let t = r.render(&view, s)?;
            if k >= warmup {
                runs.push(t);
            }
        }
        times = meniscus::timing::median_times(&runs);
    }
    let img = r.state().read_final()?;
    meniscus::output::write_png(&out, &img)?;
    eprintln!(
        "{}: {} particles, radius {}, {}×{} on {} → {}",
        job.label,
        job.first.len(),
        s.radius,
        a.width,
        a.height,
        gpu.info.name,
        out.display()
    );
    eprintln!("camera: --camera {}", view.camera.to_arg());
    if a.timings {
        println!("median of {} frames after {} warm-up frames", a.frames.unwrap_or(5), a.warmup.unwrap_or(2));
        println!("| pass | GPU ms |\n|---|---:|");
        for (name, ms) in &times.0 {
            println!("| {name} | {ms:.3} |");
        }
        println!("| **total** | **{:.3}** |", times.total());
        // Work that runs only when the particles change (the iso grid and weights): timed in the first frame.
        for (name, ms) in first.0.iter().filter(|(n, _)| !times.0.iter().any(|(m, _)| m == n)) {
            println!("| {name} (first frame only: runs when the particles change) | {ms:.3} |");
        }
    }
    dump(&r, a, &out, &view)?;
    finish(&gpu)
}

fn check_dumps(a: &RenderArgs) -> Result<()> {
    for d in &a.dump {
        if !["depth", "smoothed", "thickness", "normals", "ssr", "final"].contains(&d.as_str()) {
            bail!("--dump {d:?}: expected some of depth, smoothed, thickness, normals, ssr, final");
        }
    }
    Ok(())
}

/// A sequence's outputs may be written: the movie (one file: not with --shard or --resume) or every frame's PNG.
fn check_sequence_outputs(
    a: &RenderArgs,
    all: &[sequence::Frame],
    movie: Option<FileKind>,
    names: &Numbered,
) -> Result<()> {
    match movie {
        Some(kind) => {
            if a.resume || a.shard.is_some() {
                bail!(
                    "--out {}: a movie is one file; for --shard or --resume render PNG frames, then `meniscus \
                     encode` them (README: On a cluster)",
                    a.out.display()
                );
            }
            check_out("--out", &a.out, kind)?;
        }
        None => {
            for f in all {
                check_out("--out", &names.path(f.number), FileKind::Png)?;
            }
        }
    }
    Ok(())
}

/// The frames to render: all, or with --resume those whose PNG is not whole at this job's size (a broken one is
/// rendered again, and said).
fn frames_to_render(a: &RenderArgs, all: &[sequence::Frame], names: &Numbered) -> Vec<sequence::Frame> {
    let done = |n: u64| -> bool {
        let p = names.path(n);
        if !p.is_file() {
            return false;
        }
        match meniscus::output::check_png(&p, a.width, a.height) {
            Ok(()) => true,
            Err(why) => {
                eprintln!("--resume: {}: {why}; rendering it again", p.display());
                false
            }
        }
    };
    if a.resume {
        all.iter().filter(|f| !done(f.number)).cloned().collect()
    } else {
        all.to_vec()
    }
}

/// The noise's amplitude needs the two frames before (the change of velocity): a frame whose predecessors were
/// not rendered here (`fed`: the last frame the tracker saw; a shard's first, after --resume) gets them loaded
/// first, so every frame looks the same however the sequence is split. `job.whole` is sorted by number: a
/// binary search, not a scan per frame of a long sequence.
fn prime_motion(job: &Job, number: u64, fed: Option<u64>, tracker: &mut meniscus::motion::MotionTracker) {
    let whole = &job.whole;
    let at = whole.partition_point(|f| f.number < number);
    let at = if whole.get(at).is_some_and(|f| f.number == number) { at } else { 0 };
    if at > 0 && fed != Some(whole[at - 1].number) {
        *tracker = job.motion();
        for f in &whole[at.saturating_sub(2)..at] {
            match meniscus::scene::load_with(&f.path, &job.load) {
                Ok(p) => drop(tracker.next(&p)),
                Err(_) => *tracker = job.motion(),
            }
        }
    }
}

/// The writer thread: PNGs, or the movie's frames into ffmpeg (which encodes beside the rendering); the channel
/// the frames go to it by, and its count of frames written.
type Writer = (std::sync::mpsc::SyncSender<(PathBuf, image::RgbaImage)>, std::thread::JoinHandle<Result<usize>>);

/// Start the [`Writer`] of a sequence (`movie`: the movie's kind, else PNGs).
fn start_writer(a: &RenderArgs, job: &Job, movie: Option<FileKind>) -> Result<Writer> {
    let mut sink = match movie {
        Some(kind) => {
            let fps = a.movie.fps.or(job.fps).unwrap_or(25.0);
            eprintln!("encoding {} at {fps} frames/s with ffmpeg", a.out.display());
            Some(crate::movie::Movie::start(&a.out, kind, a.width, a.height, fps, &a.movie)?)
        }
        None => None,
    };
    let (tx, rx) = std::sync::mpsc::sync_channel::<(PathBuf, image::RgbaImage)>(2);
    let writer = std::thread::spawn(move || -> Result<usize> {
        let mut n = 0;
        for (path, img) in rx {
            match sink.as_mut() {
                Some(m) => m.push(&img)?,
                None => meniscus::output::write_png(&path, &img)?,
            }
            n += 1;
        }
        if let Some(m) = sink.take() {
            m.finish()?;
        }
        Ok(n)
    });
    Ok((tx, writer))
}

/// The folder a file is in, as the summary names it ("." for the working folder).
fn folder_of(path: &std::path::Path) -> String {
    path.parent().map(|p| p.display().to_string()).filter(|p| !p.is_empty()).unwrap_or(".".into())
}

/// The movie's flags are refused, not ignored, where no movie is written.
fn refuse_movie_flags(a: &RenderArgs) -> Result<()> {
    if a.movie.fps.is_some() || a.movie.crf.is_some() || a.movie.ffmpeg_args.is_some() {
        bail!("--fps, --crf and --ffmpeg-args apply to a movie (a sequence with --out NAME.mp4, .webm or .gif)");
    }
    Ok(())
}

/// Render a sequence to numbered PNGs: background prefetch, progress bar, camera fitted once to the sequence.
fn render_sequence(a: &RenderArgs, job: &Job) -> Result<()> {
    let all = job.frames.clone().expect("a sequence");
    if !a.dump.is_empty() || a.timings {
        bail!("--dump and --timings apply to single frames (`bench --scenes SEQ` times a sequence)");
    }
    let movie = FileKind::by_extension(&a.out, &MOVIE_KINDS).ok();
    if movie.is_none() {
        refuse_movie_flags(a)?;
    }
    let names = Numbered::new(&a.out, "png");
    check_sequence_outputs(a, &all, movie, &names)?;
    let frames = frames_to_render(a, &all, &names);
    if frames.is_empty() {
        eprintln!("--resume: all {} frames are already written", all.len());
        return Ok(());
    }
    let sky = a.skybox.as_deref().map(meniscus::scene::sky::load_faces).transpose()?;
    let gpu = a.gpu.open()?;
    let mut r = Renderer::with_frames(&gpu, a.frames_in_flight as usize)?;
    job.apply_background(&mut r)?;
    let s = &job.settings;
    let mut view = job.view(a.width, a.height);
    if let Some((size, faces)) = &sky {
        r.set_background(Backdrop::Sky { size: *size, faces })?;
        view.env.sky_cube = true;
    }
    eprintln!("{}", job.summary(Some((a.width, a.height))));
    let total = frames.len();
    eprintln!(
        "{}: {total} frames ({} … {}) on {}{}",
        a.scene.input,
        frames[0].number,
        frames[total - 1].number,
        gpu.info.name,
        if total < all.len() { format!(" ({} already written: --resume)", all.len() - total) } else { String::new() }
    );
    let bar = crate::args::progress(total as u64, "frames");
    let t0 = std::time::Instant::now();
    let mut gpu_ms = 0.0;
    // The overlap: frame n+1 loads on the prefetch thread and frame n−1's PNG encodes on the writer thread
    // while frame n renders; up to `frames_in_flight` frames are on the GPU at once (each copies its image
    // into its slot's readback buffer, taken before the slot is reused). The camera was fitted once.
    let (tx, writer) = start_writer(a, job, movie)?;
    let mut pending = std::collections::VecDeque::new();
    let mut strays_warned = None;
    let mut mesh_said = None;
    let mut skipped = vec![];
    let mut rendered = 0usize;
    let mut take =
        |r: &mut Renderer, (sub, path, name): (meniscus::device::Submitted, PathBuf, String)| -> Result<bool> {
            let img = r.read_submitted(sub)?;
            gpu_ms += r.finish(sub)?.total();
            rendered += 1;
            bar.set_message(format!("{name} → {}", path.display()));
            bar.inc(1);
            // A closed channel means the writer failed: its error is reported below.
            Ok(tx.send((path, img)).is_ok())
        };
    let (mut tracker, mut fed) = (job.motion(), None);
    let mut foam = match a.diffuse.as_deref() {
        None => None,
        Some("") => Some(Foam::Walk(Box::new(crate::diffuse::Walk::new(job)?))),
        Some(pattern) => {
            let files = sequence::resolve_all(pattern).with_context(|| format!("--diffuse {pattern}"))?;
            Some(Foam::Files(files.into_iter().map(|f| (f.number, f.path)).collect()))
        }
    };
    let mut diffuse_total = 0usize;
    let run = (|| -> Result<()> {
        // The iso surface's analysis of each frame (its box and bricks) on the prefetch thread, beside its load.
        let ahead = job.analyser();
        for (frame, loaded) in Prefetch::start_with(frames, job.load.clone(), 2, ahead) {
            let (particles, analysis) = match loaded {
                Ok(p) => p,
                Err(e) if a.skip_bad_frames => {
                    bar.suspend(|| eprintln!("warning: skipping frame {}: {e}", frame.number));
                    skipped.push(frame.number);
                    continue;
                }
                Err(e) => return Err(e.into()),
            };
            prime_motion(job, frame.number, fed, &mut tracker);
            fed = Some(frame.number);
            job.upload_next(&mut r, &particles, &mut tracker, analysis.as_ref())?;
            if let Some(src) = foam.as_mut() {
                let ps = src.particles(frame.number, &particles)?;
                diffuse_total += ps.len();
                r.upload(Upload::Diffuse { particles: &ps, settings: s })?;
            }
            job.place_bodies(&mut view, frame.number);
            let sub = r.submit(FrameRequest::new(&view, s).readback())?;
            crate::job::warn_strays(&r, s, &mut strays_warned);
            crate::job::say_mesh_path(&r, s, &mut mesh_said);
            let name = frame.path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
            pending.push_back((sub, names.path(frame.number), name));
            if pending.len() >= r.slots().count() && !take(&mut r, pending.pop_front().expect("non-empty"))? {
                return Ok(());
            }
        }
        Ok(())
    })();
    // Frames already on the GPU are finished and written even when a later frame failed.
    while let Some(p) = pending.pop_front() {
        if !take(&mut r, p)? {
            break;
        }
    }
    drop(tx);
    let written = writer.join().map_err(|_| anyhow::anyhow!("the PNG writer panicked"))?;
    bar.finish_and_clear();
    let secs = t0.elapsed().as_secs_f64();
    let n_written = *written.as_ref().unwrap_or(&0);
    let place = match movie {
        Some(_) => a.out.display().to_string(),
        None => folder_of(&names.path(all[0].number)),
    };
    let per_frame = |x: f64| x / rendered.max(1) as f64;
    let mut summary = format!(
        "{n_written} of {} frames written to {place} in {secs:.1} s ({:.2} frames/s, mean GPU frame {:.1} ms)",
        all.len(),
        rendered as f64 / secs,
        per_frame(gpu_ms)
    );
    if foam.is_some() {
        summary += &format!(", {:.0} diffuse particles per frame", per_frame(diffuse_total as f64));
    }
    eprintln!("{summary}");
    match (run, written) {
        (Err(e), _) => Err(e),
        (Ok(()), Err(e)) => Err(e.context("writing the frames")),
        (Ok(()), Ok(_)) => {
            finish(&gpu)?;
            if !skipped.is_empty() {
                let list: Vec<String> = skipped.iter().map(|n| n.to_string()).collect();
                bail!("{} frame(s) could not be read and were skipped: {}", skipped.len(), list.join(", "));
            }
            Ok(())
        }
    }
}

/// Where a sequence's diffuse particles come from (`--diffuse`).
enum Foam {
    /// Generated in time order.
    Walk(Box<crate::diffuse::Walk>),
    /// Read per frame number from an exported set.
    Files(std::collections::BTreeMap<u64, PathBuf>),
}

impl Foam {
    /// The diffuse particles of frame `number` (whose fluid is `fluid`).
    fn particles(
        &mut self,
        number: u64,
        fluid: &meniscus::scene::Particles,
    ) -> Result<Vec<meniscus::diffuse::Particle>> {
        Ok(match self {
            Foam::Walk(w) => w.advance(number, Some(fluid))?.to_vec(),
            Foam::Files(files) => {
                let path = files
                    .get(&number)
                    .with_context(|| format!("--diffuse: no file of diffuse particles for frame {number}"))?;
                meniscus::diffuse::io::load(path)?
            }
        })
    }
}

/// The files `--dump` writes beside the output PNG `out`, each with the dump's name.
fn dump_paths(a: &RenderArgs, out: &std::path::Path) -> Vec<(String, PathBuf)> {
    let path = |n: &str, ext: &str| dump_path(out, n, ext);
    let mut v = vec![];
    for d in &a.dump {
        match d.as_str() {
            "depth" | "smoothed" | "thickness" => v.push((d.clone(), path(d, "npy"))),
            "normals" => {
                v.push((d.clone(), path(d, "npy")));
                v.push((d.clone(), path(d, "png")));
            }
            "ssr" => v.push((d.clone(), path(d, "png"))),
            _ => {}
        }
    }
    v
}

/// The file of dump `name` beside the output PNG `out`: `OUT.NAME.EXT`.
fn dump_path(out: &std::path::Path, name: &str, ext: &str) -> PathBuf {
    PathBuf::from(format!("{}.{name}.{ext}", out.with_extension("").display()))
}

fn dump(r: &Renderer, a: &RenderArgs, out: &std::path::Path, view: &View) -> Result<()> {
    let Some(t) = r.state().targets() else { return Ok(()) };
    let path = |n: &str, ext: &str| dump_path(out, n, ext);
    for d in &a.dump {
        match d.as_str() {
            "depth" | "smoothed" | "thickness" => {
                let img = match d.as_str() {
                    "depth" => &t.depth,
                    "smoothed" => r.state().smoothed_depth().expect("rendered"),
                    _ => &t.thickness,
                };
                let data = r.state().read_f32(img)?;
                let p = path(d, "npy");
                meniscus::output::write_npy(&p, &[img.extent.height as usize, img.extent.width as usize], &data)?;
                eprintln!("wrote {}", p.display());
            }
            "normals" => {
                let raw = r.state().read_image(&t.normals)?;
                let words: Vec<u32> = bytemuck::pod_collect_to_vec(&raw);
                let mut data = Vec::with_capacity(words.len() * 3);
                for w in words {
                    let n = if w == 0 { [0.0; 3] } else { meniscus::renderer::unpack_normal(w) };
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
                let hits: Vec<u32> = bytemuck::pod_collect_to_vec(&r.state().read_image(&t.ssr)?);
                let scene: Vec<u16> = bytemuck::pod_collect_to_vec(&r.state().read_image(&t.scene_color)?);
                let (w, h) = (view.width, view.height);
                let png = image::RgbaImage::from_fn(w, h, |x, y| {
                    match meniscus::renderer::decode_ssr(hits[(y * w + x) as usize]) {
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
