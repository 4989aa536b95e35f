//! The one bounded reader of every input file, and the record of what this process has read.
//!
//! Every file Meniscus reads (particles, sequences' frames, `scene.json` and its OBJ bodies, background meshes,
//! settings, sky images) goes through [`read`] or [`note`]: only regular files are read (a device such as
//! `/dev/zero` or a pipe would grow without bound), and none larger than [`MAX_FILE_BYTES`]. Each is recorded
//! by its canonical path so that [`crate::output`] can refuse to write over it: an output must never cost the
//! user an input. The record is process-wide because inputs are read at many depths (a scene.json names OBJ
//! files, a sequence resolves its frames) and a writer must see all of them without each caller passing a list.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use crate::error::{Error, Result};

/// The largest input file read (4 GiB): a 1 M-particle BGEO with velocity, density and id is about 40 MB.
pub const MAX_FILE_BYTES: u64 = 4 << 30;

static INPUTS: Mutex<BTreeSet<PathBuf>> = Mutex::new(BTreeSet::new());

/// Whether a file at a path would be read as a frame of an input sequence (`scene::sequence::would_join`).
pub type Member = Box<dyn Fn(&Path) -> bool + Send>;

/// The sequences this process reads, by their spec, with the test of what would join them.
static SEQUENCES: Mutex<Vec<(String, Member)>> = Mutex::new(Vec::new());

/// The canonical form of `path` for comparisons: the file's own if it exists, else its folder's joined with the
/// name (an output that does not exist yet), else the path as given.
pub fn canonical(path: &Path) -> PathBuf {
    if let Ok(p) = path.canonicalize() {
        return p;
    }
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    match (dir.canonicalize(), path.file_name()) {
        (Ok(d), Some(name)) => d.join(name),
        _ => path.to_path_buf(),
    }
}

/// Record `path` as an input of this process (outputs may not overwrite it).
pub fn note(path: &Path) {
    let c = canonical(path);
    INPUTS.lock().unwrap_or_else(|e| e.into_inner()).insert(c);
}

/// Record the sequence `spec` as an input of this process: outputs may not become frames of it (`member` tells
/// whether a path would be read as one).
pub fn note_sequence(spec: &str, member: Member) {
    let mut g = SEQUENCES.lock().unwrap_or_else(|e| e.into_inner());
    if !g.iter().any(|(s, _)| s == spec) {
        g.push((spec.to_string(), member));
    }
}

/// The input sequence a file at `path` would become a frame of, if any.
pub fn joined_sequence(path: &Path) -> Option<String> {
    let g = SEQUENCES.lock().unwrap_or_else(|e| e.into_inner());
    g.iter().find(|(_, member)| member(path)).map(|(spec, _)| spec.clone())
}

/// Whether `path` is a file this process has read or been told it will read.
pub fn is_input(path: &Path) -> bool {
    let c = canonical(path);
    INPUTS.lock().unwrap_or_else(|e| e.into_inner()).contains(&c)
}

/// Check that `path` can be read as an input file: it exists, is a regular file (not a device, pipe or folder)
/// and holds at most [`MAX_FILE_BYTES`]. Returns its size.
pub fn check(path: &Path) -> Result<u64> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if meta.is_dir() {
        return Err(Error::Invalid(format!("{}: is a folder, not a file", path.display())));
    }
    if !meta.is_file() {
        return Err(Error::Invalid(format!(
            "{}: not a regular file (a device, pipe or socket); input files are read from disk",
            path.display()
        )));
    }
    if meta.len() > MAX_FILE_BYTES {
        return Err(Error::Limit(format!(
            "{}: {} bytes, more than the {} bytes an input file may hold",
            path.display(),
            meta.len(),
            MAX_FILE_BYTES
        )));
    }
    Ok(meta.len())
}

/// Read a whole input file, bounded ([`check`]), and record it as an input.
pub fn read(path: &Path) -> Result<Vec<u8>> {
    let len = check(path)?;
    note(path);
    let mut bytes = Vec::with_capacity(len as usize);
    use std::io::Read;
    std::fs::File::open(path)
        .and_then(|f| f.take(MAX_FILE_BYTES + 1).read_to_end(&mut bytes))
        .map_err(|e| Error::io(path, e))?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(Error::Limit(format!("{}: grew past {} bytes while being read", path.display(), MAX_FILE_BYTES)));
    }
    Ok(bytes)
}

/// Read a whole input file as UTF-8 text, bounded, and record it as an input.
pub fn read_text(path: &Path) -> Result<String> {
    let bytes = read(path)?;
    String::from_utf8(bytes).map_err(|e| Error::Parse {
        path: path.to_path_buf(),
        offset: e.utf8_error().valid_up_to() as u64,
        reason: "not UTF-8 text".into(),
    })
}

/// The memory this machine has available now (`MemAvailable` of /proc/meminfo), in bytes; `None` where that
/// cannot be read. What large allocations are checked against before they are made.
pub fn available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_and_folders_are_refused_before_reading() {
        let e = read(Path::new("/dev/zero")).unwrap_err().to_string();
        assert!(e.contains("not a regular file"), "{e}");
        let e = read(Path::new("/")).unwrap_err().to_string();
        assert!(e.contains("folder"), "{e}");
    }

    #[test]
    fn read_files_are_recorded_as_inputs() {
        let d = std::env::temp_dir().join(format!("meniscus-input-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let f = d.join("a.txt");
        std::fs::write(&f, "x").unwrap();
        assert!(!is_input(&f));
        assert_eq!(read_text(&f).unwrap(), "x");
        assert!(is_input(&f) && is_input(&d.join(".").join("a.txt")));
        std::fs::remove_dir_all(&d).unwrap();
    }
}
