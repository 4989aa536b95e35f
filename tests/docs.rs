//! The repository reads as a product: the README is a front page (≤ 150 lines), doc headings name subjects (≤ 80
//! characters, no commit hashes, no issue numbers), nothing cites files outside the repository (`method.md`,
//! `../shared/docs`), every repository path named in a doc or a comment exists, `benches/results` is data with an
//! index (no logs), and lib.rs's module doc lists every public module. Each check is a function over text, and each
//! is shown rejecting a bad example (its negative control) before it is run on the tree.

use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Every file under `dir` (relative to the root) whose name ends with one of `exts`.
fn files(dir: &str, exts: &[&str]) -> Vec<PathBuf> {
    let mut out = vec![];
    let mut stack = vec![root().join(dir)];
    while let Some(d) = stack.pop() {
        let Ok(rd) = std::fs::read_dir(&d) else { continue };
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if exts.iter().any(|x| p.to_string_lossy().ends_with(x)) {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// A word of 7–40 hex digits with at least one digit and one letter: a commit hash.
fn has_hash(s: &str) -> bool {
    s.split(|c: char| !c.is_ascii_alphanumeric()).any(|w| {
        (7..=40).contains(&w.len())
            && w.chars().all(|c| c.is_ascii_hexdigit() && !c.is_ascii_uppercase())
            && w.chars().any(|c| c.is_ascii_digit())
            && w.chars().any(|c| c.is_ascii_alphabetic())
    })
}

/// `#` followed by a digit: an issue number.
fn has_issue(s: &str) -> bool {
    s.as_bytes().windows(2).any(|w| w[0] == b'#' && w[1].is_ascii_digit())
}

/// What is wrong with the markdown headings of `text` (outside code blocks): one line per bad heading.
fn bad_headings(text: &str) -> Vec<String> {
    let mut out = vec![];
    let mut code = false;
    for (i, l) in text.lines().enumerate() {
        if l.trim_start().starts_with("```") {
            code = !code;
        }
        if code || !l.starts_with('#') {
            continue;
        }
        let h = l.trim_start_matches('#').trim();
        let n = h.chars().count();
        if n > 80 || has_hash(h) || has_issue(h) {
            out.push(format!(
                "line {}: {h:?} ({n} characters{}{})",
                i + 1,
                if has_hash(h) { ", a commit hash" } else { "" },
                if has_issue(h) { ", an issue number" } else { "" }
            ));
        }
    }
    out
}

/// The repository paths `text` names (`src/…`, `docs/…`, …), as written.
fn named_paths(text: &str) -> Vec<String> {
    const ROOTS: [&str; 9] =
        ["src/", "tests/", "tools/", "docs/", "shaders_glsl/", "benches/", "python/", "blender/", "examples/"];
    let is_path_char = |c: char| c.is_ascii_alphanumeric() || "._/-".contains(c);
    let mut out = vec![];
    let b = text.as_bytes();
    for r in ROOTS {
        let mut from = 0;
        while let Some(k) = text[from..].find(r) {
            let at = from + k;
            from = at + r.len();
            // Only where the path starts a word (not `../shared/docs/…` or `x/src/…`).
            if at > 0 && (is_path_char(b[at - 1] as char)) {
                continue;
            }
            let end = text[at..].find(|c: char| !is_path_char(c)).map_or(text.len(), |e| at + e);
            let next = text[end..].chars().next();
            let p = text[at..end].trim_end_matches(['.', '-', '/']);
            // A pattern or a placeholder is not a path: `{}`, `*`, `NAME`, `x.rs`, a prefix like `filter_`.
            if matches!(next, Some('{' | '*' | '…' | '<' | '[')) || p.ends_with('_') || p.contains("NAME") {
                continue;
            }
            if p.rsplit('/').next().is_some_and(|f| f.starts_with("x.") || f == "TARGET") {
                continue;
            }
            out.push(p.to_string());
        }
    }
    out
}

/// The named paths of `text` that do not exist under `base` (folders the tools create when they run excepted).
fn missing_paths(text: &str, base: &Path) -> Vec<String> {
    const GENERATED: [&str; 3] = ["tools/fuzz/corpus", "tools/fuzz/artifacts", "tools/fuzz/target"];
    named_paths(text)
        .into_iter()
        .filter(|p| !GENERATED.iter().any(|g| p.starts_with(g)))
        .filter(|p| !base.join(p).exists())
        .collect()
}

#[test]
fn the_checks_reject_what_they_should() {
    assert!(has_hash("The cast (93f1277, 2026-11-28)") && !has_hash("wave 1920x1080, 2026-11-28, 0.5 ms"));
    assert!(has_issue("Missing (#13)") && !has_issue("the `#` of a heading"));
    let bad = "# Fine\n## Speed: the iso cast 350 → 135 ms (9b44162, 2026-11-22)\n```\n# not a heading 1234abc\n```\n";
    assert_eq!(bad_headings(bad).len(), 1, "{:?}", bad_headings(bad));
    assert_eq!(bad_headings(&format!("## {}\n", "a".repeat(81))).len(), 1);
    let text = "see src/lib.rs, src/nowhere.rs and shaders_glsl/iso*.comp, src/passes/NAME.rs, ../shared/docs/x.md";
    assert_eq!(named_paths(text), ["src/lib.rs", "src/nowhere.rs"]);
    assert_eq!(missing_paths(text, &root()), ["src/nowhere.rs"]);
}

#[test]
fn the_readme_is_a_front_page() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let n = readme.lines().count();
    assert!(n <= 150, "README.md has {n} lines (at most 150: the rest belongs in docs/)");
    assert_eq!(bad_headings(&readme), Vec::<String>::new());
    for link in ["docs/guide.md", "docs/cli.md", "docs/limitations.md", "benches/results/README.md"] {
        assert!(readme.contains(link), "README.md does not link {link}");
    }
}

#[test]
fn doc_headings_name_their_subject() {
    let mut bad = vec![];
    for f in files("docs", &[".md"]) {
        for b in bad_headings(&std::fs::read_to_string(&f).unwrap()) {
            bad.push(format!("{}: {b}", f.display()));
        }
    }
    assert!(bad.is_empty(), "headings that are not subjects:\n{}", bad.join("\n"));
}

#[test]
fn nothing_cites_files_outside_the_repository() {
    let mut bad = vec![];
    for dir in ["src", "shaders_glsl", "docs", "tools"] {
        for f in files(dir, &[".rs", ".glsl", ".comp", ".md", ".py", ".sh", ""]) {
            let Ok(t) = std::fs::read_to_string(&f) else { continue };
            for (i, l) in t.lines().enumerate() {
                if l.contains("method.md") || l.contains("../shared/docs") {
                    bad.push(format!("{}:{}: {}", f.display(), i + 1, l.trim()));
                }
            }
        }
    }
    assert!(bad.is_empty(), "citations of files outside the repository (cite the paper):\n{}", bad.join("\n"));
}

#[test]
fn every_path_named_in_docs_and_comments_exists() {
    let mut sources: Vec<PathBuf> = vec![root().join("README.md"), root().join("build.rs")];
    sources.extend(files("docs", &[".md"]));
    sources.extend(files("src", &[".rs"]));
    sources.extend(files("shaders_glsl", &[".glsl", ".comp"]));
    sources.extend(files("tools", &[".py", ".sh", "gpu-bundle", "dev", "wheel", "race-splashsurf"]));
    sources.push(root().join("benches/README.md"));
    let mut bad = vec![];
    for f in sources {
        let Ok(t) = std::fs::read_to_string(&f) else { continue };
        for p in missing_paths(&t, &root()) {
            bad.push(format!("{}: {p}", f.display()));
        }
    }
    assert!(bad.is_empty(), "paths that do not exist:\n{}", bad.join("\n"));
}

#[test]
fn results_are_data_with_an_index() {
    let dir = root().join("benches/results");
    let index = std::fs::read_to_string(dir.join("README.md")).expect("benches/results/README.md: the index");
    let mut unlisted = vec![];
    for e in std::fs::read_dir(&dir).unwrap().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if name != "README.md" && !index.contains(&format!("[{name}]({name})")) {
            unlisted.push(name);
        }
    }
    assert!(unlisted.is_empty(), "result sets missing from benches/results/README.md: {unlisted:?}");
    let logs: Vec<_> = files("benches/results", &[".log", ".txt"]);
    assert!(logs.is_empty(), "logs in benches/results (the JSON is the record): {logs:?}");
    // Data, not a journal: at most 150 files and 5 MB (a set of several runs keeps them in one runs.json).
    let all = files("benches/results", &[""]);
    let bytes: u64 = all.iter().map(|f| std::fs::metadata(f).map_or(0, |m| m.len())).sum();
    assert!(all.len() <= 150, "benches/results holds {} files (at most 150)", all.len());
    assert!(bytes <= 5_000_000, "benches/results holds {bytes} bytes (at most 5 MB)");
}

#[test]
fn the_library_doc_lists_every_module() {
    let lib = std::fs::read_to_string(root().join("src/lib.rs")).unwrap();
    let doc: String = lib.lines().filter(|l| l.starts_with("//!")).collect::<Vec<_>>().join("\n");
    let mut missing = vec![];
    for l in lib.lines() {
        if let Some(m) = l.strip_prefix("pub mod ") {
            let m = m.trim_end_matches([';', '{', ' ']);
            if m != "gpu" && !doc.contains(&format!("[`{m}`]")) {
                missing.push(m.to_string());
            }
        }
    }
    assert!(missing.is_empty(), "lib.rs's module doc does not list {missing:?}");
    // The check sees a module left out.
    assert!(!"//! [`scene`]".contains("[`sim`]"));
}
