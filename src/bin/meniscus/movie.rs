//! Movies: frames piped to ffmpeg (Debian's `ffmpeg`, which `tools/dev` installs) as raw RGBA, encoded to MP4
//! (H.264), WebM (VP9) or an animated GIF, written under the library's partial name and renamed into place only
//! when ffmpeg succeeds — so an interrupted or failing encode leaves no movie rather than a broken one. ffmpeg is
//! a separate process; it is used, not re-implemented, because it is what every user's player expects.
//! Used by `render SEQ --out movie.mp4` (the encode overlaps the rendering) and `encode` (PNG frames → movie,
//! the cheap last step of a cluster render).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};

use anyhow::{bail, Context, Result};
use clap::Args;

use meniscus::output::{FileKind, Partial};

/// The movie formats `--out` may name.
pub const MOVIE_KINDS: [FileKind; 3] = [FileKind::Mp4, FileKind::Webm, FileKind::Gif];

/// How a movie is encoded (shared by `render` and `encode`).
#[derive(Args, Clone, Debug, Default)]
pub struct MovieArgs {
    /// Movie frame rate (default: the sequence's own, from its scene.json's dataExportFPS, else 25).
    #[arg(long, value_parser = crate::args::finite::<f32>, allow_negative_numbers = true)]
    pub fps: Option<f32>,
    /// Movie quality: ffmpeg's constant rate factor (lower is better; default 18 for MP4, 32 for WebM).
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=63))]
    pub crf: Option<u32>,
    /// Extra ffmpeg arguments placed before the output (split at spaces), e.g. "-preset slow -tune animation".
    /// ffmpeg runs with -n: a file named there is never overwritten.
    #[arg(long, allow_hyphen_values = true, value_name = "ARGS")]
    pub ffmpeg_args: Option<String>,
}

/// A movie being encoded: frames go to ffmpeg's stdin.
pub struct Movie {
    child: Child,
    stdin: Option<ChildStdin>,
    stderr: Option<std::thread::JoinHandle<String>>,
    partial: Option<Partial>,
    path: PathBuf,
    size: (u32, u32),
    frames: usize,
}

impl Movie {
    /// Start ffmpeg for a `width`×`height` movie of `kind` at `path`.
    pub fn start(path: &Path, kind: FileKind, width: u32, height: u32, fps: f32, a: &MovieArgs) -> Result<Movie> {
        if !(fps.is_finite() && fps > 0.0 && fps <= 1000.0) {
            bail!("--fps {fps}: expected a frame rate in (0, 1000]");
        }
        let partial = Partial::begin(path, kind)?;
        let mut cmd = Command::new("ffmpeg");
        // `-n`: ffmpeg never overwrites a file. Ours is a fresh partial name; a path in --ffmpeg-args is taken by
        // ffmpeg as one more output, and must not replace an input that happens to be named there.
        cmd.args(["-hide_banner", "-loglevel", "error", "-nostdin", "-n", "-f", "rawvideo", "-pix_fmt", "rgba"]);
        cmd.args(["-s", &format!("{width}x{height}"), "-framerate", &fps.to_string(), "-i", "pipe:0"]);
        // H.264 and VP9 in yuv420p need even sizes: pad by one pixel where needed.
        let even = "pad=ceil(iw/2)*2:ceil(ih/2)*2";
        match kind {
            FileKind::Mp4 => {
                let crf = a.crf.unwrap_or(18).to_string();
                cmd.args(["-vf", even, "-c:v", "libx264", "-pix_fmt", "yuv420p", "-crf", &crf]);
                cmd.args(["-movflags", "+faststart", "-f", "mp4"]);
            }
            FileKind::Webm => {
                let crf = a.crf.unwrap_or(32).to_string();
                cmd.args(["-vf", even, "-c:v", "libvpx-vp9", "-pix_fmt", "yuv420p", "-b:v", "0", "-crf", &crf]);
                cmd.args(["-row-mt", "1", "-f", "webm"]);
            }
            _ => {
                cmd.args(["-vf", "split[a][b];[a]palettegen[p];[b][p]paletteuse", "-f", "gif"]);
            }
        }
        if let Some(extra) = &a.ffmpeg_args {
            cmd.args(extra.split_whitespace());
        }
        cmd.arg(partial.tmp()).stdin(Stdio::piped()).stdout(Stdio::null()).stderr(Stdio::piped());
        let mut child = cmd.spawn().map_err(|e| {
            if e.kind() == std::io::ErrorKind::NotFound {
                anyhow::anyhow!(
                    "{}: movies are encoded by ffmpeg, which is not installed (apt-get install ffmpeg; tools/dev \
                     installs it)",
                    path.display()
                )
            } else {
                anyhow::anyhow!("{}: cannot start ffmpeg: {e}", path.display())
            }
        })?;
        let stdin = child.stdin.take();
        let mut err = child.stderr.take().expect("piped");
        let stderr = std::thread::spawn(move || {
            let mut s = String::new();
            let _ = std::io::Read::read_to_string(&mut err, &mut s);
            s
        });
        Ok(Movie {
            child,
            stdin,
            stderr: Some(stderr),
            partial: Some(partial),
            path: path.to_path_buf(),
            size: (width, height),
            frames: 0,
        })
    }

    /// The movie's size.
    pub fn size(&self) -> (u32, u32) {
        self.size
    }

    /// Append one frame (the movie's size).
    pub fn push(&mut self, img: &image::RgbaImage) -> Result<()> {
        if img.dimensions() != self.size {
            bail!(
                "{}: frame {} is {}×{}, the movie is {}×{}",
                self.path.display(),
                self.frames + 1,
                img.width(),
                img.height(),
                self.size.0,
                self.size.1
            );
        }
        let w = self.stdin.as_mut().expect("open until finish");
        if let Err(e) = w.write_all(img.as_raw()) {
            // ffmpeg stopped: its own message says why.
            self.stdin = None;
            let _ = self.child.wait();
            let msg = self.stderr.take().and_then(|h| h.join().ok()).unwrap_or_default();
            bail!("{}: ffmpeg stopped ({e}): {}", self.path.display(), msg.trim());
        }
        self.frames += 1;
        Ok(())
    }

    /// Close the stream, wait for ffmpeg and put the movie in place; returns the frame count.
    pub fn finish(mut self) -> Result<usize> {
        drop(self.stdin.take());
        let status = self.child.wait().context("waiting for ffmpeg")?;
        let msg = self.stderr.take().and_then(|h| h.join().ok()).unwrap_or_default();
        if !status.success() {
            bail!("{}: ffmpeg failed ({status}): {}", self.path.display(), msg.trim());
        }
        if self.frames == 0 {
            bail!("{}: no frames to encode", self.path.display());
        }
        // ffmpeg can exit 0 having failed to write its output (a full disk: "Error writing trailer", a file
        // without its index). The movie replaces an existing one only when ffmpeg reported no error, the
        // file is on disk (synced) and it decodes to every frame that was sent.
        if let Some(line) = msg.lines().find(|l| {
            let l = l.to_ascii_lowercase();
            l.contains("error") || l.contains("no space left")
        }) {
            bail!("{}: ffmpeg reported an error, the movie is not kept: {}", self.path.display(), line.trim());
        }
        let partial = self.partial.take().expect("until finish");
        std::fs::File::open(partial.tmp())
            .and_then(|f| f.sync_all())
            .with_context(|| format!("{}: the encoded movie could not be written to disk", self.path.display()))?;
        let decoded = count_frames(partial.tmp())
            .with_context(|| format!("{}: the encoded movie could not be checked", self.path.display()))?;
        if decoded != self.frames {
            bail!(
                "{}: the encoded movie decodes to {decoded} of its {} frames (a full disk or a failed write?); \
                 the movie is not kept",
                self.path.display(),
                self.frames
            );
        }
        let n = self.frames;
        partial.commit()?;
        Ok(n)
    }
}

/// The frames a movie file decodes to (ffprobe, which comes with ffmpeg, decodes every frame); an error when
/// it cannot be read at all.
pub fn count_frames(path: &Path) -> Result<usize> {
    let o = Command::new("ffprobe")
        .args(["-v", "error", "-count_frames", "-select_streams", "v:0"])
        .args(["-show_entries", "stream=nb_read_frames", "-of", "csv=p=0"])
        .arg(path)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| anyhow::anyhow!("cannot run ffprobe (it comes with ffmpeg: apt-get install ffmpeg): {e}"))?;
    let out = String::from_utf8_lossy(&o.stdout);
    let err = String::from_utf8_lossy(&o.stderr);
    if !o.status.success() {
        bail!("ffprobe cannot read it: {}", err.trim());
    }
    // No video stream (a file cut before its first frame) prints nothing.
    Ok(out.trim().trim_end_matches(',').parse().unwrap_or(0))
}

impl Drop for Movie {
    fn drop(&mut self) {
        // An unfinished movie: stop ffmpeg; the partial file goes with `partial`.
        if self.stdin.take().is_some() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// `meniscus encode`.
#[derive(Args, Clone, Debug)]
pub struct EncodeArgs {
    /// PNG frames: a pattern with {} for the frame number ('png/f_{}.png'), a folder or a glob; in frame order.
    frames: String,
    /// The movie: .mp4, .webm or .gif.
    #[arg(short, long)]
    out: PathBuf,
    #[command(flatten)]
    movie: MovieArgs,
}

/// Encode numbered PNG frames (a `render` or a cluster's shards) into one movie.
pub fn encode(a: &EncodeArgs) -> Result<()> {
    let kind = crate::args::out_kind("--out", &a.out, &MOVIE_KINDS)?;
    let frames = meniscus::scene::sequence::resolve_files(&a.frames, &["png"], "PNG")?;
    crate::args::check_out("--out", &a.out, kind)?;
    let gaps = meniscus::scene::sequence::missing(&frames);
    if !gaps.is_empty() {
        bail!(
            "{}: {} frame(s) missing from the numbering (first: {}): render them first",
            a.frames,
            gaps.len(),
            gaps[0]
        );
    }
    let load = |p: &Path| -> Result<image::RgbaImage> {
        meniscus::input::check(p)?;
        Ok(image::open(p).with_context(|| format!("{}: not a readable image", p.display()))?.to_rgba8())
    };
    let first = load(&frames[0].path)?;
    let mut movie = Movie::start(&a.out, kind, first.width(), first.height(), a.movie.fps.unwrap_or(25.0), &a.movie)?;
    let bar = crate::args::progress(frames.len() as u64, "frames");
    movie.push(&first)?;
    bar.inc(1);
    for f in &frames[1..] {
        movie.push(&load(&f.path)?)?;
        bar.inc(1);
    }
    let n = movie.finish()?;
    bar.finish_and_clear();
    eprintln!("{n} frames → {}", a.out.display());
    Ok(())
}
