//! The library's layout as a property: its top-level modules form no import cycle (a module reaches another
//! only downwards), so a technique, the frame and the renderer can each be read on their own. Scans the
//! `crate::NAME` paths of every source file outside tests and comments.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Every `.rs` file under `dir`, its folders walked (but not `skip`, a folder name).
fn rust_files(dir: &Path, skip: Option<&str>) -> Vec<PathBuf> {
    let mut out = vec![];
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            if skip.is_none_or(|s| p.file_name().unwrap() != s) {
                out.extend(rust_files(&p, skip));
            }
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
    out
}

/// The applications' code lines (the CLI, demo and bench in `src/bin`, the Python package, the example a user
/// starts from), comments cut:
/// ("path:line", code).
fn app_lines() -> Vec<(String, String)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let files = [
        rust_files(&root.join("src/bin"), None),
        rust_files(&root.join("python/src"), None),
        vec![root.join("examples/render_frame.rs")],
    ]
    .concat();
    let mut lines = vec![];
    for p in files {
        let text = std::fs::read_to_string(&p).unwrap();
        for (i, line) in text.lines().enumerate() {
            lines.push((format!("{}:{}", p.display(), i + 1), line.split("//").next().unwrap().to_string()));
        }
    }
    lines
}

/// The applications' code lines that name `path` ("path:line: code").
fn app_lines_naming(path: &str) -> Vec<String> {
    app_lines()
        .into_iter()
        .filter(|(_, code)| code.contains(path))
        .map(|(at, code)| format!("{at}: {}", code.trim()))
        .collect()
}

/// Every library source file (not `src/bin`) and its code before any `#[cfg(test)]`.
fn library_code() -> Vec<(PathBuf, String)> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    rust_files(&src, Some("bin"))
        .into_iter()
        .map(|p| {
            let text = std::fs::read_to_string(&p).unwrap();
            let code = text.split("#[cfg(test)]").next().unwrap().to_string();
            (p, code)
        })
        .collect()
}

/// The node a file belongs to: its top-level module, except a settings section's own file (`params.rs`: the
/// `[iso]` section in `surface/iso/params.rs`), which is a node of its own — `settings` gathers the sections,
/// so a section lives with what reads it only if its file is a leaf that `settings` may import without
/// importing that module's whole folder.
fn node_of(rel: &Path) -> String {
    let parts: Vec<String> = rel.iter().map(|c| c.to_string_lossy().trim_end_matches(".rs").to_string()).collect();
    if parts.len() > 1 && parts.last().is_some_and(|l| l == "params") {
        return parts.join("::");
    }
    parts[0].clone()
}

/// The node a `crate::a::b::…` path names: a section's own node when the path goes through it, else `a`.
fn node_named(path: &str, sections: &BTreeSet<String>) -> String {
    let segments: Vec<&str> = path.split("::").collect();
    (2..=segments.len())
        .rev()
        .map(|k| segments[..k].join("::"))
        .find(|p| sections.contains(p))
        .unwrap_or_else(|| segments[0].to_string())
}

fn scan(src: &Path, graph: &mut BTreeMap<String, BTreeSet<String>>) {
    let files: Vec<PathBuf> = rust_files(src, None)
        .into_iter()
        .filter(|p| {
            let rel = p.strip_prefix(src).unwrap();
            // (A module's tests in their own file, `mod tests;` under `#[cfg(test)]`, are not library code.)
            !rel.starts_with("bin") && !rel.ends_with("tests.rs") && !rel.ends_with("lib.rs")
        })
        .collect();
    let nodes: Vec<(String, &PathBuf)> = files.iter().map(|p| (node_of(p.strip_prefix(src).unwrap()), p)).collect();
    let sections: BTreeSet<String> = nodes.iter().map(|(n, _)| n.clone()).filter(|n| n.contains("::")).collect();
    for (module, p) in nodes {
        let text = std::fs::read_to_string(p).unwrap();
        let code = text.split("#[cfg(test)]").next().unwrap();
        let deps = graph.entry(module.clone()).or_default();
        for line in code.lines() {
            let line = line.split("//").next().unwrap();
            for part in line.split("crate::").skip(1) {
                let path: String = part
                    .chars()
                    .take_while(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || "_:".contains(*c))
                    .collect();
                let dep = node_named(path.trim_end_matches(':'), &sections);
                if !dep.is_empty() && dep != module {
                    deps.insert(dep);
                }
            }
        }
    }
}

/// A cycle of `graph` (each node's imports), if it has one: depth-first search for a back edge.
fn find_cycle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        n: &str,
        g: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        path: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        match state.get(n) {
            Some(1) => return Some(path.iter().skip_while(|m| *m != n).cloned().chain([n.to_string()]).collect()),
            Some(2) => return None,
            _ => {}
        }
        state.insert(n.to_string(), 1);
        path.push(n.to_string());
        for d in g.get(n).into_iter().flatten().filter(|d| g.contains_key(*d)) {
            if let Some(c) = visit(d, g, state, path) {
                return Some(c);
            }
        }
        path.pop();
        state.insert(n.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    graph.keys().find_map(|n| visit(n, graph, &mut state, &mut vec![]))
}

#[test]
fn the_top_level_modules_form_no_cycle() {
    let mut graph = BTreeMap::new();
    scan(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"), &mut graph);
    let names: BTreeSet<String> = graph.keys().cloned().collect();
    assert!(names.contains("surface") && names.contains("renderer") && names.len() > 15, "{names:?}");
    // A section's file is its own node, named by its path; `settings` imports it, not its folder.
    assert!(graph["settings"].contains("surface::iso::params") && !graph["settings"].contains("surface"));
    if let Some(cycle) = find_cycle(&graph) {
        panic!("import cycle among the library's modules: {}", cycle.join(" -> "));
    }
    // The controls: settings importing the iso surface's folder (not its section) closes a cycle, as would a
    // section that imported what reads it.
    let mut folder = graph.clone();
    folder.get_mut("settings").unwrap().insert("surface".into());
    assert!(find_cycle(&folder).is_some(), "settings -> surface -> settings was not found");
    let mut section = graph.clone();
    section.get_mut("surface::iso::params").unwrap().insert("settings".into());
    assert!(find_cycle(&section).is_some(), "a section importing settings was not found");
    let sections = ["surface::iso::params".to_string()].into();
    assert_eq!(node_named("surface::iso::params::Params", &sections), "surface::iso::params");
    assert_eq!(node_named("surface::iso::cast", &sections), "surface");
}

/// The applications (the CLI, demo and bench in `src/bin`, the Python package) use the library's public API:
/// none of them reaches into `passes` (a frame pass's internals: read-back decoders and pass names are
/// `renderer` functions, the GPU marching cubes and neighbour grid live in `compute`).
#[test]
fn apps_do_not_reach_into_the_passes() {
    let hits = app_lines_naming("meniscus::passes");
    assert!(hits.is_empty(), "apps reach into meniscus::passes:\n{}", hits.join("\n"));
}

/// No source file is over 700 lines — the library's (tests in their own `tests.rs` included) and the
/// applications' in `src/bin`: a file holds one concern.
#[test]
fn no_source_file_is_over_700_lines() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let long: Vec<String> = rust_files(&src, None)
        .into_iter()
        .filter_map(|p| {
            let n = std::fs::read_to_string(&p).unwrap().lines().count();
            (n > 700).then(|| format!("{} ({n} lines)", p.display()))
        })
        .collect();
    assert!(long.is_empty(), "library files over 700 lines: {long:?}");
}

/// Each function of `code` that is over `limit` lines, as (name, first line, lines): a `fn` line at some indent
/// up to the `}` line at the same indent (rustfmt's layout).
fn long_functions(code: &str, limit: usize) -> Vec<(String, usize, usize)> {
    let lines: Vec<&str> = code.lines().collect();
    let mut out = vec![];
    for (i, l) in lines.iter().enumerate() {
        let t = l.trim_start();
        let indent = l.len() - t.len();
        let t = t
            .strip_prefix("pub ")
            .or_else(|| t.strip_prefix("pub(crate) "))
            .or_else(|| t.strip_prefix("pub(super) "))
            .unwrap_or(t);
        let Some(rest) = t.strip_prefix("fn ") else { continue };
        let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
        // A declaration without a body (a trait's) ends with ';' before any '{'.
        let Some(open) =
            (i..lines.len()).find(|&k| lines[k].trim_end().ends_with('{') || lines[k].trim_end().ends_with(';'))
        else {
            continue;
        };
        if lines[open].trim_end().ends_with(';') {
            continue;
        }
        let close = format!("{}}}", " ".repeat(indent));
        if let Some(end) = (open + 1..lines.len()).find(|&k| lines[k] == close) {
            let n = end - i + 1;
            if n > limit {
                out.push((name, i + 1, n));
            }
        }
    }
    out
}

/// No function is over 150 lines, in the library, the applications or the Python package: a function does one
/// thing.
#[test]
fn no_function_is_over_150_lines() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let long: Vec<String> = [rust_files(&root.join("src"), None), rust_files(&root.join("python/src"), None)]
        .concat()
        .into_iter()
        .flat_map(|p| {
            let code = std::fs::read_to_string(&p).unwrap();
            long_functions(&code, 150)
                .into_iter()
                .map(move |(f, at, n)| format!("{}:{at} {f} ({n} lines)", p.display()))
        })
        .collect();
    assert!(long.is_empty(), "functions over 150 lines: {long:#?}");
    // The control: a function of 151 lines is found, one of 150 is not, a trait's declaration is no function.
    let body = |n: usize| format!("    pub fn f() {{\n{}    }}\n", "        x();\n".repeat(n - 2));
    assert_eq!(long_functions(&body(151), 150), vec![("f".to_string(), 1, 151)]);
    assert!(long_functions(&body(150), 150).is_empty());
    assert!(long_functions("    fn g(&self);\n    fn h() {\n    }\n", 0).len() == 1);
}

/// The renderer's door stays small: at most 13 public methods on `Renderer` (src/renderer/mod.rs), its
/// requests, state and parts in their own types (`state()` reads, `parts_mut()` changes), and no public field.
#[test]
fn the_renderer_door_stays_small() {
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("src/renderer/mod.rs")).unwrap();
    let block = text.split("impl Renderer {").nth(1).expect("impl Renderer").split("\n}\n").next().unwrap();
    let methods: Vec<&str> = block.lines().filter(|l| l.starts_with("    pub fn ")).collect();
    assert!(methods.len() <= 13, "Renderer has {} public methods: {methods:#?}", methods.len());
    let fields = text.split("pub struct Renderer {").nth(1).expect("struct Renderer").split("\n}\n").next().unwrap();
    let public: Vec<&str> =
        fields.lines().filter(|l| l.starts_with("    pub ") && !l.starts_with("    pub(")).collect();
    assert!(public.is_empty(), "Renderer has public fields: {public:#?}");
}

/// An effect written outside the library (tests/effects.rs) needs neither the passes nor the device layer: the
/// effect vocabulary (`Layer`, `Blend`, `Detail`) is `meniscus::layer`'s, the device types are
/// `meniscus::device`'s.
#[test]
fn an_outside_effect_imports_neither_passes_nor_the_device_layer() {
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/effects.rs")).unwrap();
    let code: Vec<&str> = text.lines().filter(|l| !l.trim_start().starts_with("//")).collect();
    for name in ["meniscus::passes", "meniscus::gpu"] {
        let hits: Vec<&&str> = code.iter().filter(|l| l.contains(name)).collect();
        assert!(hits.is_empty(), "tests/effects.rs names {name}: {hits:?}");
    }
    assert!(code.iter().any(|l| l.contains("meniscus::effect::")), "the check reads the wrong file");
}

/// The applications use the device through `meniscus::device` (the device, what a hook records with, a frame's
/// handles, the bench's queue ids): none of them names the device layer, `meniscus::gpu`, which is the
/// library's own (hidden from its documentation; the integration tests drive passes through it).
#[test]
fn apps_do_not_reach_into_the_device_layer() {
    let hits = app_lines_naming("meniscus::gpu");
    assert!(hits.is_empty(), "apps reach into meniscus::gpu (use meniscus::device):\n{}", hits.join("\n"));
}

/// Every public item has one documented path: a `pub use` in the library names items of a private module
/// declared beside it (`mod m;` then `pub use m::{…}`: the module's items get their one public path), or, in
/// `src/device.rs`, items of the device layer, which `lib.rs` hides from the documentation. No item is
/// re-exported under a second public path (`pub mod m;` plus `pub use m::X`, or `pub use crate::…` elsewhere).
#[test]
fn every_public_item_has_one_path() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let lib = std::fs::read_to_string(src.join("lib.rs")).unwrap();
    assert!(lib.contains("#[doc(hidden)]\npub mod gpu;"), "lib.rs no longer hides the device layer");
    let mut bad = vec![];
    for (p, code) in library_code() {
        for (i, line) in code.lines().enumerate() {
            let Some(path) = line.trim_start().strip_prefix("pub use ") else { continue };
            let first = path.split("::").next().unwrap();
            let ok = if p.ends_with("device.rs") {
                path.starts_with("crate::gpu::")
            } else {
                !["crate", "self", "super"].contains(&first)
                    && code.lines().any(|l| l.trim() == format!("mod {first};"))
            };
            if !ok {
                bad.push(format!("{}:{}: {}", p.display(), i + 1, line.trim()));
            }
        }
    }
    assert!(bad.is_empty(), "items with a second public path:\n{}", bad.join("\n"));
}

/// No public type name means two things: each `pub struct/enum/trait/type` name of the library is declared once,
/// but `Params` (a settings section: each pass module's, `passes::ssr::Params` is `[ssr]`) and `Push` (a
/// pass's push constants), which are named by their module by design.
#[test]
fn no_type_name_is_declared_twice() {
    let mut seen: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for (p, code) in library_code() {
        for line in code.lines() {
            let t = line.trim_start();
            for kind in ["pub struct ", "pub enum ", "pub trait ", "pub type "] {
                if let Some(rest) = t.strip_prefix(kind) {
                    let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
                    seen.entry(name).or_default().push(p.display().to_string());
                }
            }
        }
    }
    let twice: Vec<String> = seen
        .into_iter()
        .filter(|(n, at)| at.len() > 1 && n != "Params" && n != "Push")
        .map(|(n, at)| format!("{n}: {at:?}"))
        .collect();
    assert!(twice.is_empty(), "type names declared twice:\n{}", twice.join("\n"));
}

/// The names a technique or effect file `code` uses of its siblings (`siblings`, in module `parent`) or of the
/// renderer: `super::NAME`, `crate::PARENT::NAME`, `crate::renderer`.
fn sibling_uses(code: &str, parent: &str, own: &str, siblings: &[&str]) -> Vec<String> {
    let mut hits = vec![];
    for line in code.lines().filter(|l| !l.trim_start().starts_with("//")) {
        for s in siblings.iter().filter(|s| **s != own) {
            if line.contains(&format!("super::{s}::")) || line.contains(&format!("crate::{parent}::{s}::")) {
                hits.push(format!("{own}: {}", line.trim()));
            }
        }
        if line.contains("crate::renderer") {
            hits.push(format!("{own}: {}", line.trim()));
        }
    }
    hits
}

/// A technique (`src/surface/`: spheres, iso, mesh) or an effect (`src/effect/`: noise, diffuse) imports
/// neither another of its kind nor the renderer: what two share lives apart (`surface::grid`, the depth splat).
#[test]
fn techniques_and_effects_import_neither_each_other_nor_the_renderer() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    // The control: a spheres file that reached into the iso surface is caught.
    assert_eq!(sibling_uses("use super::iso::IsoResources;", "surface", "spheres", &["spheres", "iso"]).len(), 1);
    let mut hits = vec![];
    for (parent, members) in
        [("surface", ["spheres", "iso", "mesh"].as_slice()), ("effect", ["noise", "diffuse"].as_slice())]
    {
        for own in members {
            let file = root.join(parent).join(format!("{own}.rs"));
            let files = if file.exists() { vec![file] } else { rust_files(&root.join(parent).join(own), None) };
            assert!(!files.is_empty(), "no source for {parent}::{own}");
            for f in files {
                hits.extend(sibling_uses(&std::fs::read_to_string(&f).unwrap(), parent, own, members));
            }
        }
    }
    assert!(hits.is_empty(), "techniques or effects reach into each other or the renderer:\n{}", hits.join("\n"));
}
