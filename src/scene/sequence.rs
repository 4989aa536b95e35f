//! Particle sequences: a pattern with `{}` (`ParticleData_Fluid_{}.bgeo`), a folder, or a glob
//! (`frames/*.vtk`), sorted by frame NUMBER (SPlisHSPlasH does not zero-pad), restricted by a frame range
//! (`10..40:2`, inclusive) and a shard (`2/8`: every 8th frame starting with the 2nd, for render farms).
//! [`Prefetch`] loads frames on a background thread, at most `depth` ahead, so rendering does not wait on I/O
//! and memory stays constant over long sequences.

use std::path::{Path, PathBuf};
use std::sync::mpsc;

use crate::error::{Error, Result};
use crate::scene::{LoadOptions, Particles};

/// One frame of a sequence.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Frame {
    /// The frame number taken from the file name.
    pub number: u64,
    /// The file.
    pub path: PathBuf,
}

/// `first..last[:step]`, inclusive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameRange {
    /// First frame number.
    pub first: u64,
    /// Last frame number (inclusive).
    pub last: u64,
    /// Step between frames.
    pub step: u64,
}

impl FrameRange {
    /// Parse `a..b`, `a..b:s`, `a..`, `..b`, or a single `a`.
    pub fn parse(s: &str) -> Result<FrameRange> {
        let bad = || Error::Invalid(format!("bad --frames {s:?}: expected FIRST..LAST[:STEP], e.g. 10..40:2"));
        let (range, step) = match s.split_once(':') {
            Some((r, st)) => (r, st.trim().parse::<u64>().map_err(|_| bad())?),
            None => (s, 1),
        };
        if step == 0 {
            return Err(bad());
        }
        let (first, last) = match range.split_once("..") {
            Some((a, b)) => (
                if a.trim().is_empty() { 0 } else { a.trim().parse().map_err(|_| bad())? },
                if b.trim().is_empty() {
                    u64::MAX
                } else {
                    b.trim().trim_start_matches('=').parse().map_err(|_| bad())?
                },
            ),
            None => {
                let a = range.trim().parse().map_err(|_| bad())?;
                (a, a)
            }
        };
        if first > last {
            return Err(bad());
        }
        Ok(FrameRange { first, last, step })
    }

    /// Whether frame `n` is in the range.
    pub fn contains(&self, n: u64) -> bool {
        n >= self.first && n <= self.last && (n - self.first).is_multiple_of(self.step)
    }
}

/// `k/n` with 1 ≤ k ≤ n.
pub fn parse_shard(s: &str) -> Result<(usize, usize)> {
    let bad = || Error::Invalid(format!("bad --shard {s:?}: expected K/N with 1 ≤ K ≤ N, e.g. 2/8"));
    let (k, n) = s.split_once('/').ok_or_else(bad)?;
    let (k, n): (usize, usize) = (k.trim().parse().map_err(|_| bad())?, n.trim().parse().map_err(|_| bad())?);
    if k == 0 || n == 0 || k > n {
        return Err(bad());
    }
    Ok((k, n))
}

/// Where the last run of digits in a file name's stem (before its last '.') starts and ends.
fn last_digits(name: &str) -> Option<(usize, usize)> {
    let stem = name.rsplit_once('.').map(|(s, _)| s).unwrap_or(name);
    let end = stem.rfind(|c: char| c.is_ascii_digit())? + 1;
    let start = stem[..end].rfind(|c: char| !c.is_ascii_digit()).map(|i| i + 1).unwrap_or(0);
    Some((start, end))
}

/// The last run of digits in a file name, as a frame number.
fn frame_number(name: &str) -> Option<u64> {
    let (start, end) = last_digits(name)?;
    name[start..end].parse().ok()
}

/// True when `spec` names a sequence rather than one file: a pattern with {}, a glob, a folder, or a ParaView
/// `.pvd` collection.
pub fn is_sequence(spec: &str) -> bool {
    spec.contains("{}") || spec.contains('*') || spec.contains('?') || Path::new(spec).is_dir() || is_pvd(spec)
}

/// True when a file at `path` would be read as a frame of the sequence `spec` (a pattern with {}: the same
/// folder, prefix and suffix around digits; a folder: a particle file in it; a glob: a match): an output there
/// would join the input on its next read.
pub fn would_join(spec: &str, path: &Path) -> bool {
    let same_dir = |a: &Path, b: &Path| {
        let canon = |p: &Path| {
            let p = if p.as_os_str().is_empty() { Path::new(".") } else { p };
            std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf())
        };
        canon(a) == canon(b)
    };
    let name = path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
    let dir = path.parent().unwrap_or(Path::new("."));
    if let Some((pre, post)) = spec.split_once("{}") {
        let pre_path = Path::new(pre);
        let (sdir, prefix) = if pre.ends_with('/') {
            (pre_path, String::new())
        } else {
            (
                pre_path.parent().unwrap_or(Path::new(".")),
                pre_path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default(),
            )
        };
        let mid = name.strip_prefix(&prefix).and_then(|m| m.strip_suffix(post));
        return same_dir(sdir, dir) && mid.is_some_and(|m| !m.is_empty() && m.bytes().all(|b| b.is_ascii_digit()));
    }
    if Path::new(spec).is_dir() {
        let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
        return same_dir(Path::new(spec), dir) && super::format::extensions().any(|x| x == ext);
    }
    glob::Pattern::new(spec).is_ok_and(|g| g.matches_path(path))
}

fn is_pvd(spec: &str) -> bool {
    Path::new(spec).extension().is_some_and(|e| e.eq_ignore_ascii_case("pvd"))
}

/// The frames of a ParaView `.pvd` collection (`<DataSet timestep=… file=…/>`, paths relative to the .pvd), in
/// timestep order; frame numbers are the positions in that order (0, 1, …). Several parts per timestep are
/// not supported (an error says so).
pub fn read_pvd(path: &Path) -> Result<Vec<Frame>> {
    use quick_xml::events::Event;
    let bytes = crate::input::read(path)?;
    let err = |at: usize, r: String| super::bytes::err_at(path, at, r);
    let dir =
        path.parent().map(|p| if p.as_os_str().is_empty() { Path::new(".") } else { p }).unwrap_or(Path::new("."));
    let mut rd = quick_xml::Reader::from_reader(&bytes[..]);
    let mut buf = vec![];
    let mut sets: Vec<(f64, usize, PathBuf)> = vec![];
    let mut collection = false;
    loop {
        let at = rd.buffer_position() as usize;
        match rd.read_event_into(&mut buf) {
            Err(e) => return Err(err(at, format!("malformed XML: {e}"))),
            Ok(Event::Eof) => break,
            Ok(Event::Start(e)) | Ok(Event::Empty(e)) => {
                let get = |k: &str| {
                    e.attributes()
                        .flatten()
                        .find(|a| a.key.as_ref() == k.as_bytes())
                        .map(|a| String::from_utf8_lossy(&a.value).into_owned())
                };
                match e.name().as_ref() {
                    b"VTKFile" => collection = get("type").as_deref() == Some("Collection"),
                    b"DataSet" => {
                        let file = get("file").ok_or_else(|| err(at, "<DataSet> lacks file=".into()))?;
                        let t = match get("timestep") {
                            Some(t) => t.trim().parse().map_err(|_| err(at, format!("bad timestep {t:?}")))?,
                            None => sets.len() as f64,
                        };
                        let part: usize = get("part").and_then(|p| p.trim().parse().ok()).unwrap_or(0);
                        if !t.is_finite() {
                            return Err(err(at, format!("timestep {t} is not finite")));
                        }
                        sets.push((t, part, dir.join(file)));
                    }
                    _ => {}
                }
            }
            Ok(_) => {}
        }
        buf.clear();
    }
    if !collection {
        return Err(err(0, "not a ParaView collection (expected <VTKFile type=\"Collection\">)".into()));
    }
    if sets.iter().any(|s| s.1 != 0) {
        return Err(err(0, "collections with several parts per timestep are not supported".into()));
    }
    sets.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(sets.into_iter().enumerate().map(|(k, (_, _, p))| Frame { number: k as u64, path: p }).collect())
}

/// Resolve a pattern, folder or glob to frames sorted by number, filtered by `range` and `shard`.
pub fn resolve(spec: &str, range: Option<FrameRange>, shard: Option<(usize, usize)>) -> Result<Vec<Frame>> {
    select(spec, resolve_all(spec)?, range, shard)
}

/// Every frame of a pattern, folder or glob, sorted by number; each file is recorded as an input of this
/// process ([`crate::input::note`]), and the pattern, folder or glob itself ([`crate::input::note_sequence`]),
/// so no output of the run can overwrite a frame or become one.
pub fn resolve_all(spec: &str) -> Result<Vec<Frame>> {
    let exts: Vec<&str> = super::format::extensions().collect();
    resolve_files(spec, &exts, "particle")
}

/// The pattern of a numbered file name: its last run of digits (in the stem) replaced by `{}`.
fn name_pattern(name: &str) -> Option<String> {
    let (start, end) = last_digits(name)?;
    Some(format!("{}{{}}{}", &name[..start], &name[end..]))
}

/// The frame number of a numbered file name (`dir/f_16.bgeo` → 16): its stem's last run of digits.
pub fn number_of(path: &Path) -> Option<u64> {
    frame_number(&path.file_name()?.to_string_lossy())
}

/// The sequence pattern a numbered file belongs to (`dir/f_16.bgeo` → `dir/f_{}.bgeo`), for [`resolve_all`].
pub fn numbered_pattern(path: &Path) -> Option<String> {
    let name = name_pattern(&path.file_name()?.to_string_lossy())?;
    Some(path.with_file_name(name).to_string_lossy().into_owned())
}

/// A folder's files with one of `exts` as one sequence: the files must share one numbered name pattern (or
/// none be numbered, then they are taken in name order); a folder holding several sequences (the particles and
/// an export beside them) is refused with the patterns it holds, so the user names one.
fn folder_files(spec: &str, exts: &[&str], what: &str) -> Result<Vec<PathBuf>> {
    let rd = std::fs::read_dir(spec).map_err(|e| Error::io(spec, e))?;
    let mut files: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.is_file()
                && p.extension()
                    .and_then(|e| e.to_str())
                    .is_some_and(|e| exts.contains(&e.to_ascii_lowercase().as_str()))
        })
        .collect();
    files.sort();
    let mut groups: std::collections::BTreeMap<String, usize> = Default::default();
    for f in &files {
        let name = f.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        *groups.entry(name_pattern(&name).unwrap_or(name)).or_default() += 1;
    }
    let numbered = groups.keys().filter(|k| k.contains("{}")).count();
    if numbered > 1 || (numbered == 1 && groups.len() > 1) {
        let dir = spec.trim_end_matches('/');
        let list: Vec<String> =
            groups.iter().map(|(k, n)| format!("'{dir}/{k}' ({n} file{})", if *n == 1 { "" } else { "s" })).collect();
        return Err(Error::Invalid(format!(
            "{spec}: the folder holds {} {what} sequences or files: {}; name the one to read by its pattern",
            groups.len(),
            list.join(", ")
        )));
    }
    Ok(files)
}

/// Every frame of a pattern, folder or glob whose files are of `what` kind (a folder's files are those ending in
/// one of `exts`), sorted by number, recorded as inputs like [`resolve_all`].
pub fn resolve_files(spec: &str, exts: &[&str], what: &str) -> Result<Vec<Frame>> {
    let mut frames: Vec<Frame> = if is_pvd(spec) {
        read_pvd(Path::new(spec))?
    } else if let Some((pre, post)) = spec.split_once("{}") {
        let pre_path = Path::new(pre);
        let (dir, prefix) = if pre.ends_with('/') {
            (pre_path.to_path_buf(), String::new())
        } else {
            (
                pre_path
                    .parent()
                    .map(|p| if p.as_os_str().is_empty() { Path::new(".") } else { p })
                    .unwrap_or(Path::new("."))
                    .to_path_buf(),
                pre_path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default(),
            )
        };
        let rd = std::fs::read_dir(&dir).map_err(|e| Error::io(&dir, e))?;
        rd.filter_map(|e| e.ok())
            .filter_map(|e| {
                let name = e.file_name().to_string_lossy().into_owned();
                let mid = name.strip_prefix(&prefix)?.strip_suffix(post)?;
                if mid.is_empty() || !mid.bytes().all(|b| b.is_ascii_digit()) {
                    return None;
                }
                Some(Frame { number: mid.parse().ok()?, path: e.path() })
            })
            .collect()
    } else if Path::new(spec).is_dir() {
        numbered(folder_files(spec, exts, what)?)
    } else {
        let paths = glob::glob(spec).map_err(|e| Error::Invalid(format!("bad glob {spec:?}: {e}")))?;
        let mut files: Vec<PathBuf> = paths.filter_map(|p| p.ok()).filter(|p| p.is_file()).collect();
        files.sort();
        numbered(files)
    };
    if frames.is_empty() {
        return Err(Error::Invalid(if Path::new(spec).is_dir() {
            format!("{spec}: the folder holds no {what} files (.{})", exts.join(", ."))
        } else {
            format!("{spec}: no {what} files match")
        }));
    }
    frames.sort_by(|a, b| a.number.cmp(&b.number).then_with(|| a.path.cmp(&b.path)));
    for f in &frames {
        crate::input::note(&f.path);
    }
    if !is_pvd(spec) {
        let owned = spec.to_string();
        crate::input::note_sequence(spec, Box::new(move |p| would_join(&owned, p)));
    }
    Ok(frames)
}

/// The frames of `frames` (all of a sequence, sorted) that `range` and `shard` select.
pub fn select(
    spec: &str,
    mut frames: Vec<Frame>,
    range: Option<FrameRange>,
    shard: Option<(usize, usize)>,
) -> Result<Vec<Frame>> {
    if let Some(r) = range {
        frames.retain(|f| r.contains(f.number));
    }
    if let Some((k, n)) = shard {
        frames = frames.into_iter().enumerate().filter(|(i, _)| i % n == k - 1).map(|(_, f)| f).collect();
    }
    if frames.is_empty() {
        return Err(Error::Invalid(format!("{spec}: no frames left after --frames/--shard")));
    }
    Ok(frames)
}

/// The frame numbers missing from a sequence (sorted by number) that steps regularly: with the step the
/// greatest common divisor of the differences between consecutive numbers, the numbers between the first and
/// the last that no file has. Empty when the numbering is too irregular to tell (more gaps than frames).
pub fn missing(frames: &[Frame]) -> Vec<u64> {
    fn gcd(a: u64, b: u64) -> u64 {
        if b == 0 {
            a
        } else {
            gcd(b, a % b)
        }
    }
    let step = frames.windows(2).map(|w| w[1].number - w[0].number).fold(0, gcd);
    let (Some(first), Some(last)) = (frames.first(), frames.last()) else { return vec![] };
    if step == 0 || (last.number - first.number) / step + 1 > 2 * frames.len() as u64 {
        return vec![];
    }
    let have: std::collections::BTreeSet<u64> = frames.iter().map(|f| f.number).collect();
    (first.number..=last.number).step_by(step as usize).filter(|n| !have.contains(n)).collect()
}

/// Number files by the digits in their names (or their position when a name has none).
fn numbered(files: Vec<PathBuf>) -> Vec<Frame> {
    let all_numbered = files.iter().all(|p| p.file_name().and_then(|n| frame_number(&n.to_string_lossy())).is_some());
    files
        .into_iter()
        .enumerate()
        .map(|(i, path)| {
            let number = if all_numbered {
                frame_number(&path.file_name().unwrap().to_string_lossy()).unwrap()
            } else {
                i as u64
            };
            Frame { number, path }
        })
        .collect()
}

/// Loads frames on a background thread, at most `depth` ahead of the consumer; with [`Prefetch::start_with`]
/// each loaded frame's `A` is computed there too (the host's analysis a frame's upload takes:
/// `crate::surface::grid::analyse`), so the render thread does not walk the particles for it.
pub struct Prefetch<A = ()> {
    rx: mpsc::Receiver<(Frame, Result<(Particles, A)>)>,
    handle: Option<std::thread::JoinHandle<()>>,
}

impl Prefetch<()> {
    /// Start loading `frames` on a worker thread, at most `depth` frames ahead of the consumer.
    pub fn start(frames: Vec<Frame>, opts: LoadOptions, depth: usize) -> Prefetch<()> {
        Prefetch::start_with(frames, opts, depth, |_| ())
    }
}

impl<A: Send + 'static> Prefetch<A> {
    /// [`Prefetch::start`], with `then` of each loaded frame computed on the worker thread after its load.
    pub fn start_with(
        frames: Vec<Frame>,
        opts: LoadOptions,
        depth: usize,
        then: impl Fn(&Particles) -> A + Send + 'static,
    ) -> Prefetch<A> {
        let (tx, rx) = mpsc::sync_channel(depth.max(1));
        let handle = std::thread::Builder::new()
            .name("meniscus-prefetch".into())
            .spawn(move || {
                for f in frames {
                    let p = crate::scene::load_with(&f.path, &opts).map(|p| {
                        let a = then(&p);
                        (p, a)
                    });
                    if tx.send((f, p)).is_err() {
                        return; // consumer gone
                    }
                }
            })
            .expect("spawn prefetch thread");
        Prefetch { rx, handle: Some(handle) }
    }
}

impl<A> Iterator for Prefetch<A> {
    type Item = (Frame, Result<(Particles, A)>);
    fn next(&mut self) -> Option<Self::Item> {
        self.rx.recv().ok()
    }
}

impl<A> Drop for Prefetch<A> {
    fn drop(&mut self) {
        // Unblock the loader (its next send fails) and wait for it.
        let (_tx, rx) = mpsc::sync_channel(1);
        drop(std::mem::replace(&mut self.rx, rx));
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Once a sequence is read, an output whose name it would read as a frame (the same folder, prefix and
    /// suffix around digits) is refused; another name in the same folder is not.
    #[test]
    fn outputs_may_not_join_an_input_sequence() {
        let dir = std::env::temp_dir().join(format!("meniscus-join-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for n in [1, 2] {
            std::fs::write(dir.join(format!("f_{n}.bgeo")), b"").unwrap();
        }
        let spec = format!("{}/f_{{}}.bgeo", dir.display());
        assert_eq!(resolve_all(&spec).unwrap().len(), 2);
        let kind = crate::output::FileKind::Bgeo;
        let e = crate::output::check_output(&dir.join("f_0003.bgeo"), kind).unwrap_err().to_string();
        assert!(e.contains("would become a frame of the input sequence"), "{e}");
        crate::output::check_output(&dir.join("foam_0003.bgeo"), kind).unwrap();
        crate::output::check_output(&dir.join("f_0003.bgeo.gz"), kind).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn ranges_and_shards() {
        let r = FrameRange::parse("10..40:2").unwrap();
        assert!(r.contains(10) && r.contains(40) && !r.contains(11) && !r.contains(42));
        assert_eq!(FrameRange::parse("5").unwrap(), FrameRange { first: 5, last: 5, step: 1 });
        assert!(
            FrameRange::parse("4..2").is_err()
                && FrameRange::parse("1..5:0").is_err()
                && FrameRange::parse("x").is_err()
        );
        assert_eq!(parse_shard("2/8").unwrap(), (2, 8));
        assert!(parse_shard("0/8").is_err() && parse_shard("9/8").is_err() && parse_shard("3").is_err());
    }

    #[test]
    fn frame_numbers_from_names() {
        assert_eq!(frame_number("ParticleData_Fluid_20.bgeo"), Some(20));
        assert_eq!(frame_number("a7b_0012.vtk"), Some(12));
        assert_eq!(frame_number("none.vtk"), None);
    }

    #[test]
    fn missing_frames_are_found() {
        let f = |ns: &[u64]| -> Vec<Frame> { ns.iter().map(|&n| Frame { number: n, path: PathBuf::new() }).collect() };
        assert_eq!(missing(&f(&[1, 2, 3, 5, 6])), vec![4]);
        assert_eq!(missing(&f(&[0, 2, 4, 8])), vec![6]);
        assert!(missing(&f(&[0, 10, 20])).is_empty());
        assert!(missing(&f(&[7])).is_empty());
        assert!(missing(&f(&[1, 1000, 100000])).is_empty(), "too irregular to tell");
    }
}
