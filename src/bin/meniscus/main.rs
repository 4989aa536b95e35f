//! `meniscus` — the command line: `render` (headless to PNG, one frame or a sequence), `info` (what a particle
//! file holds), `scenes` (the built-in scenes), `bench` (per-pass GPU timings, JSON), `demo` (the window), `mesh` (marching cubes), `sim` (the GPU fluid solver's cache), `foam` (a sequence's diffuse particles).
//! Every subcommand that reads particles starts from the one [`job::Job`] set-up.

mod args;
mod bench;
mod bench_measure;
mod bench_mesh;
mod bench_report;
mod bench_sim;
mod chart;
pub(crate) mod demo;
mod diffuse;
mod info;
mod job;
mod mesh;
mod movie;
mod quality;
mod render;
mod sim;

use clap::{Parser, Subcommand};

use meniscus::scene::procedural;

#[derive(Parser)]
#[command(name = "meniscus", version, about = "Screen-space fluid rendering of SPH particles on Vulkan")]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Render one frame headless to a PNG, or a sequence to numbered PNGs or a movie (.mp4, .webm, .gif).
    Render(render::RenderArgs),
    /// Encode numbered PNG frames into a movie with ffmpeg (the last step of a render split over a cluster).
    Encode(movie::EncodeArgs),
    /// Describe a particle file: format, count, attributes, bounds, spacing and the radius a job would use.
    Info(info::InfoArgs),
    /// List the built-in procedural scenes.
    Scenes,
    /// Benchmark: scenes × resolutions, per-pass GPU medians/p95/min, memory; markdown table + JSON.
    Bench(bench::BenchArgs),
    /// Extract the SPH iso-surface as a triangle mesh (marching cubes, CPU or --gpu): PLY, OBJ or VTK.
    Mesh(mesh::MeshArgs),
    /// Generate the diffuse particles (spray, foam and air bubbles, Ihmsen 2012) of a sequence and write them per frame (.bgeo/.vtk).
    #[command(alias = "foam")]
    Diffuse(diffuse::DiffuseArgs),
    /// Measure a rendered surface: its roughness (particle rows), its distance to a reference surface's depth,
    /// and for a sequence its flicker from frame to frame (colour, normals, warping error along the velocities).
    Quality(quality::QualityArgs),
    /// Simulate a built-in scene or a SPlisHSPlasH scene file on the GPU (Position Based Fluids or DFSPH) and write a particle cache (.bgeo/.vtk).
    Sim(sim::SimArgs),
    /// Interactive window: play a sequence, fly the camera, look inside every pass.
    #[command(after_help = demo::HELP)]
    Demo(demo::DemoArgs),
    /// Print the command-line reference (every subcommand and flag with its help) as markdown: docs/cli.md.
    #[command(hide = true)]
    CliReference {
        /// Instead, one line per flag: SUBCOMMAND, FLAG and the kind of its value (switch, float, int, path,
        /// text, or one-of:A|B|…), tab-separated: what tests/flags.rs walks.
        #[arg(long)]
        flags: bool,
    },
}

/// The command-line reference as markdown, walked from clap's command tree (docs/cli.md is this output; a test
/// fails when it is stale).
fn cli_reference() -> String {
    use clap::CommandFactory;
    use std::fmt::Write;
    let mut out = String::from(
        "# Command-line reference\n\nGenerated from the code by `meniscus cli-reference > docs/cli.md` (a test fails when \
         this page is stale). Every subcommand also prints this with `--help`.\n",
    );
    let root = Cli::command();
    for sub in root.get_subcommands().filter(|c| !c.is_hide_set() && c.get_name() != "help") {
        let _ = write!(out, "\n## meniscus {}\n\n", sub.get_name());
        if let Some(a) = sub.get_long_about().or(sub.get_about()) {
            let _ = writeln!(out, "{a}\n");
        }
        let args: Vec<_> = sub.get_arguments().filter(|a| !a.is_hide_set()).collect();
        if args.is_empty() {
            out.push_str("No options.\n");
            continue;
        }
        out.push_str("| argument | help |\n|---|---|\n");
        for a in args {
            let name = match (a.get_long(), a.get_short()) {
                (Some(l), _) => format!("`--{l}`"),
                (None, Some(c)) => format!("`-{c}`"),
                (None, None) => format!("`{}`", a.get_id().as_str().to_uppercase()),
            };
            let help = a.get_long_help().or(a.get_help()).map(|h| h.to_string()).unwrap_or_default();
            let mut help = help.replace('\n', " ").replace('|', "\\|");
            let defaults: Vec<String> =
                a.get_default_values().iter().map(|v| v.to_string_lossy().into_owned()).collect();
            if !defaults.is_empty() {
                let _ = write!(help, " (default: `{}`)", defaults.join(","));
            }
            let values: Vec<String> = a.get_possible_values().iter().map(|v| v.get_name().to_string()).collect();
            if !values.is_empty() && a.get_action().takes_values() {
                let _ = write!(help, " (one of: {})", values.join(", "));
            }
            let _ = writeln!(out, "| {name} | {help} |");
        }
    }
    out
}

/// Every flag of every subcommand with the kind of value it takes, one tab-separated line each (a test feeds
/// each kind its hostile values: tests/flags.rs).
fn cli_flags() -> String {
    use clap::CommandFactory;
    use std::any::TypeId;
    let mut out = String::new();
    let root = Cli::command();
    for sub in root.get_subcommands().filter(|c| !c.is_hide_set() && c.get_name() != "help") {
        for a in sub.get_arguments().filter(|a| !a.is_hide_set()) {
            let Some(long) = a.get_long() else { continue };
            if matches!(long, "help" | "version") {
                continue;
            }
            let values: Vec<String> = a.get_possible_values().iter().map(|v| v.get_name().to_string()).collect();
            let t = a.get_value_parser().type_id();
            let kind = if !a.get_action().takes_values() {
                "switch".to_string()
            } else if !values.is_empty() {
                format!("one-of:{}", values.join("|"))
            } else if t == TypeId::of::<f32>() || t == TypeId::of::<f64>() {
                "float".to_string()
            } else if [TypeId::of::<u32>(), TypeId::of::<u64>(), TypeId::of::<usize>(), TypeId::of::<i32>()]
                .iter()
                .any(|id| t == *id)
            {
                "int".to_string()
            } else if t == TypeId::of::<std::path::PathBuf>() {
                "path".to_string()
            } else {
                "text".to_string()
            };
            out.push_str(&format!("{}\t--{long}\t{kind}\n", sub.get_name()));
        }
    }
    out
}

/// Spellings of the command line that still work but are deprecated: the `foam` subcommand and `--foam` flag
/// are `diffuse` and `--diffuse` (the diffuse particles, of which foam is one kind).
fn deprecated_spellings(args: impl Iterator<Item = String>) -> Vec<String> {
    let mut notes = vec![];
    for (k, a) in args.enumerate() {
        if k == 0 && a == "foam" {
            notes.push("`meniscus foam` is deprecated: it is `meniscus diffuse` now".to_string());
        }
        if a == "--foam" || a.starts_with("--foam=") {
            notes.push("`--foam` is deprecated: it is `--diffuse` now".to_string());
        }
    }
    notes
}

/// A closed stdout or stderr (`meniscus info FILE | head -1`) is a normal end, not a crash: Rust's print
/// macros panic on a broken pipe, so the panic hook ends the process quietly in that one case (exit 0 when the
/// reader of stdout has all it wanted, 1 when stderr is gone and nothing more can be reported), and leaves
/// every other panic to the default hook.
fn quiet_on_closed_pipes() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let msg = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if msg.starts_with("failed printing to stdout") && msg.contains("Broken pipe") {
            meniscus::output::remove_partials();
            std::process::exit(0);
        }
        if msg.starts_with("failed printing to stderr") {
            meniscus::output::remove_partials();
            std::process::exit(1);
        }
        default(info);
    }));
}

fn main() {
    quiet_on_closed_pipes();
    // SIGINT / SIGTERM: the partial files being written are removed, so an interrupted run leaves only
    // complete outputs (a SIGKILL leaves NAME.PID.partial, which the next write of NAME removes).
    let _ = ctrlc::set_handler(|| {
        meniscus::output::remove_partials();
        std::process::exit(130);
    });
    let cli = Cli::parse();
    for note in deprecated_spellings(std::env::args().skip(1)) {
        eprintln!("warning: {note}");
    }
    let r = match cli.cmd {
        Cmd::Render(a) => render::run(&a),
        Cmd::Encode(a) => movie::encode(&a),
        Cmd::Info(a) => info::run(&a),
        Cmd::Bench(a) => bench::run(&a),
        Cmd::Demo(a) => demo::main(&a),
        Cmd::Mesh(a) => mesh::run(&a),
        Cmd::Sim(a) => sim::run(&a),
        Cmd::Diffuse(a) => diffuse::run(&a),
        Cmd::Quality(a) => quality::run(&a),
        Cmd::CliReference { flags } => {
            print!("{}", if flags { cli_flags() } else { cli_reference() });
            Ok(())
        }
        Cmd::Scenes => {
            for (name, n, what) in procedural::SCENES {
                println!("{name:8} {n:>9} particles  {what}");
            }
            Ok(())
        }
    };
    if let Err(e) = r {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
