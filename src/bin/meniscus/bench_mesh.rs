//! `meniscus bench --mesh FILE`: the performance analysis of the mesh extraction across thread counts (Janisz's
//! thesis analyses its multithreaded iso-surface extraction against the single-core original). For each cube size
//! and thread count, the median of `repeat` runs of `meniscus mesh`'s own path (`surface::mesh::reconstruct`,
//! then the PLY written to a scratch file): per phase wall time — the grid and 1/n (`grid`), the blocks' scatter
//! and march (`blocks`, with their thread time), the weld, the write — the speed-up over the first thread count
//! and the parallel efficiency (thread time ÷ (wall × threads)) of the block phase; splashsurf 0.14 (when
//! installed) with the same radius, smoothing length, cube size and threshold and `--num-threads` beside it; with
//! `--mesh-gpu` the GPU path (`mc` pass) per cube size: its GPU stages and its host part. Markdown on stdout (and
//! `--markdown`), JSON with `--json`.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use serde::Serialize;

use meniscus::field::extract::ExtractParams;
use meniscus::surface::mesh::{ExtractionStats, Reconstruct};

use crate::args::{GpuArgs, LoadArgs};

/// What to measure.
pub struct Options {
    /// Thread counts (empty: 1, 2, 4, … up to the cores).
    pub threads: Vec<usize>,
    /// Cube sizes in particle radii (empty: 0.5 and 1.0).
    pub cubes: Vec<f32>,
    /// Cubes per block edge (empty: chosen from the particles and the cube size, as `mesh` does).
    pub blocks: Vec<u32>,
    /// Particle radius (default: the job's: scene.json or estimated).
    pub radius: Option<f32>,
    /// Runs per configuration.
    pub repeat: u32,
    /// Also the GPU path, on this device.
    pub gpu: Option<GpuArgs>,
}

/// One configuration's medians, seconds.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    pub cube_radii: f32,
    /// Cubes per block edge (CPU rows).
    pub block: u32,
    /// "cpu", "gpu" or "splashsurf".
    pub path: String,
    pub threads: usize,
    pub wall: f64,
    pub grid: f64,
    pub blocks: f64,
    /// Scatter + march summed over the threads.
    pub blocks_thread: f64,
    pub weld: f64,
    pub write: f64,
    /// GPU stages' sum (ms) for the GPU path.
    pub gpu_ms: f64,
    pub vertices: usize,
    pub triangles: usize,
    /// Wall of the first thread count ÷ this wall.
    pub speedup: f64,
    /// blocks_thread ÷ (blocks × threads).
    pub efficiency: f64,
}

#[derive(Serialize)]
struct Report {
    schema: u32,
    file: String,
    particles: usize,
    radius: f32,
    cores: usize,
    git_commit: String,
    rows: Vec<Row>,
}

/// One CPU run: wall, grid, the extraction's times, write, vertices, triangles.
type CpuRun = (f64, f64, meniscus::field::extract::blocks::ExtractTimes, f64, usize, usize);
/// One GPU run: wall, grid, GPU ms, host set-up, upload and copy (no weld), write, vertices, triangles.
type GpuRun = (f64, f64, f64, f64, f64, usize, usize);

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The splashsurf binary, when installed.
fn splashsurf() -> Option<PathBuf> {
    let root = std::env::var_os("SPLASHSURF_ROOT")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache/meniscus/splashsurf")))?;
    let bin = root.join("bin/splashsurf");
    bin.is_file().then_some(bin)
}

/// Run the analysis.
pub fn run(
    file: &Path,
    load: &LoadArgs,
    o: &Options,
    json: Option<&Path>,
    markdown: Option<&Path>,
    chart: Option<&Path>,
) -> Result<()> {
    use meniscus::output::FileKind;
    meniscus::input::note(file);
    if let Some(p) = json {
        crate::args::check_report("--json", p, FileKind::Json)?;
    }
    if let Some(p) = chart {
        crate::args::check_report("--chart", p, FileKind::Png)?;
    }
    if let Some(p) = markdown {
        crate::args::check_report("--markdown", p, FileKind::Markdown)?;
    }
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let threads: Vec<usize> = if o.threads.is_empty() {
        std::iter::successors(Some(1usize), |t| Some(t * 2)).take_while(|&t| t <= cores).collect()
    } else {
        o.threads.clone()
    };
    if threads.iter().any(|&t| t == 0 || t > 1024) {
        bail!("--threads: counts must be 1 … 1024");
    }
    let cubes = if o.cubes.is_empty() { vec![0.5, 1.0] } else { o.cubes.clone() };
    let block_sizes = if o.blocks.is_empty() { vec![meniscus::field::extract::AUTO_BLOCK] } else { o.blocks.clone() };
    if block_sizes.iter().any(|&b| b != meniscus::field::extract::AUTO_BLOCK && !(8..=1024).contains(&b)) {
        bail!("--block: 8 … 1024 cubes per block edge");
    }
    if cubes.iter().any(|c| !(c.is_finite() && *c > 0.05 && *c <= 8.0)) {
        bail!("--cube-size must be in (0.05, 8] particle radii");
    }
    let scene = crate::args::SceneArgs {
        input: file.to_string_lossy().into_owned(),
        radius: o.radius,
        particles: None,
        camera: None,
        background_obj: None,
        no_scene_json: false,
    };
    let job = crate::job::Job::open(&scene, load, meniscus::settings::Settings::default(), Default::default())?;
    if job.frames.is_some() {
        bail!("--mesh takes one particle file, not a sequence");
    }
    let r = job.settings.radius;
    let positions = &job.first.positions;
    eprintln!("{}", job.summary(None));
    let scratch = std::env::temp_dir().join(format!("meniscus-bench-mesh-{}.ply", std::process::id()));
    let ss = splashsurf();
    let gpu = o.gpu.as_ref().map(|g| -> Result<_> {
        let gpu = g.open()?;
        let mc = meniscus::compute::mc::Mc::new(&gpu)?;
        Ok((gpu, mc))
    });
    let gpu = gpu.transpose()?;
    let mut rows: Vec<Row> = vec![];
    let bar = crate::args::progress((cubes.len() * block_sizes.len() * threads.len()) as u64, "configurations");
    for (&cube, &block) in cubes.iter().flat_map(|c| block_sizes.iter().map(move |b| (c, b))) {
        let recon = Reconstruct {
            support: 4.0 * r,
            extract: ExtractParams { block, ..ExtractParams::new(cube * r, 0.6) },
            // `meniscus mesh`'s default: no smoothing afterwards.
            smoothing: meniscus::field::smooth::SmoothParams { iterations: 0, ..Default::default() },
        };
        let mut first_wall = None;
        for &t in &threads {
            rows.push(cpu_row(t, positions, &recon, &scratch, o.repeat, cube, &mut first_wall)?);
            // splashsurf once per cube size and thread count (the first block size).
            if let Some(bin) = ss.as_ref().filter(|_| block == block_sizes[0]) {
                rows.push(splashsurf_row(bin, file, r, cube, t, &scratch, o.repeat)?);
            }
            bar.inc(1);
        }
        if let Some((g, mc)) = gpu.as_ref().filter(|_| block == block_sizes[0]) {
            rows.push(gpu_row((g, mc), positions, &recon, &scratch, o.repeat, cube)?);
        }
    }
    bar.finish_and_clear();
    let _ = std::fs::remove_file(&scratch);
    let md = table(file, positions.len(), r, cores, &rows);
    let panels = chart.map(|_| scaling_panels(&rows));
    print!("{md}");
    if let Some(p) = markdown {
        meniscus::output::write_atomic(p, FileKind::Markdown, |w| std::io::Write::write_all(w, md.as_bytes()))?;
    }
    if let Some(p) = json {
        let report = Report {
            schema: 1,
            file: file.display().to_string(),
            particles: positions.len(),
            radius: r,
            cores,
            git_commit: crate::bench::git_commit(),
            rows,
        };
        meniscus::output::write_json(p, &report)?;
        eprintln!("wrote {}", p.display());
    }
    // The measurements first, so a chart that cannot be drawn (no font) loses nothing.
    if let (Some(p), Some(panels)) = (chart, panels) {
        crate::chart::write(
            p,
            &format!("meniscus bench --mesh {}", file.file_name().unwrap_or_default().to_string_lossy()),
            &panels,
        )?;
        eprintln!("wrote {}", p.display());
    }
    Ok(())
}

/// The CPU path at `t` threads: `repeat` runs of the reconstruction and the PLY write, their medians
/// (`first_wall`: the first thread count's wall time, which the speed-up is relative to).
fn cpu_row(
    t: usize,
    positions: &[[f32; 3]],
    recon: &Reconstruct,
    scratch: &Path,
    repeat: u32,
    cube: f32,
    first_wall: &mut Option<f64>,
) -> Result<Row> {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(t).build()?;
    let mut samples: Vec<CpuRun> = vec![];
    for _ in 0..repeat {
        let t0 = Instant::now();
        let (m, rep) = pool.install(|| meniscus::surface::mesh::reconstruct(positions, recon, None))?;
        let t_write = Instant::now();
        meniscus::output::write_mesh(scratch, m.data())?;
        let write = t_write.elapsed().as_secs_f64();
        let wall = t0.elapsed().as_secs_f64();
        let times = match rep.extraction {
            ExtractionStats::Cpu(Some(x)) => x,
            _ => Default::default(),
        };
        samples.push((wall, rep.field_s, times, write, m.vertices.len(), m.triangles.len()));
    }
    let pick = |f: &dyn Fn(&CpuRun) -> f64| median(samples.iter().map(f).collect());
    let wall = pick(&|s| s.0);
    let blocks = pick(&|s| s.2.blocks_wall);
    let blocks_thread = pick(&|s| s.2.scatter + s.2.march);
    let first = *first_wall.get_or_insert(wall);
    Ok(Row {
        cube_radii: cube,
        block: samples[0].2.block,
        path: "cpu".into(),
        threads: t,
        wall,
        grid: pick(&|s| s.1),
        blocks,
        blocks_thread,
        weld: pick(&|s| s.2.weld),
        write: pick(&|s| s.3),
        gpu_ms: 0.0,
        vertices: samples[0].4,
        triangles: samples[0].5,
        speedup: first / wall,
        efficiency: blocks_thread / (blocks * t as f64).max(1e-12),
    })
}

/// splashsurf on the same file at `t` threads as a whole process, `repeat` times: its median wall time.
fn splashsurf_row(bin: &Path, file: &Path, r: f32, cube: f32, t: usize, scratch: &Path, repeat: u32) -> Result<Row> {
    let mut walls = vec![];
    for _ in 0..repeat {
        let t0 = Instant::now();
        let out = std::process::Command::new(bin)
            .arg("reconstruct")
            .arg(file)
            .args(["--particle-radius", &r.to_string(), "--smoothing-length", "2.0"])
            .args(["--cube-size", &cube.to_string(), "--surface-threshold", "0.6"])
            .args(["--num-threads", &t.to_string(), "--output-file"])
            .arg(scratch)
            .output()
            .context("running splashsurf")?;
        if !out.status.success() {
            bail!("splashsurf failed: {}", String::from_utf8_lossy(&out.stderr).trim());
        }
        walls.push(t0.elapsed().as_secs_f64());
    }
    Ok(Row {
        cube_radii: cube,
        block: 0,
        path: "splashsurf".into(),
        threads: t,
        wall: median(walls),
        grid: 0.0,
        blocks: 0.0,
        blocks_thread: 0.0,
        weld: 0.0,
        write: 0.0,
        gpu_ms: 0.0,
        vertices: 0,
        triangles: 0,
        speedup: 0.0,
        efficiency: 0.0,
    })
}

/// The GPU path (the field and marching cubes on the device): `repeat` runs, their medians.
fn gpu_row(
    (g, mc): (&std::sync::Arc<meniscus::device::Gpu>, &meniscus::compute::mc::Mc),
    positions: &[[f32; 3]],
    recon: &Reconstruct,
    scratch: &Path,
    repeat: u32,
    cube: f32,
) -> Result<Row> {
    let mut samples: Vec<GpuRun> = vec![];
    for _ in 0..repeat {
        let t0 = Instant::now();
        let (m, rep) = meniscus::surface::mesh::reconstruct(positions, recon, Some((g, mc)))?;
        let t_write = Instant::now();
        meniscus::output::write_mesh(scratch, m.data())?;
        let write = t_write.elapsed().as_secs_f64();
        let (gpu_ms, host) = match &rep.extraction {
            ExtractionStats::Gpu(st) => (st.gpu_ms(), st.host_ms() * 1e-3),
            _ => (0.0, 0.0),
        };
        samples.push((
            t0.elapsed().as_secs_f64(),
            rep.field_s,
            gpu_ms,
            host,
            write,
            m.vertices.len(),
            m.triangles.len(),
        ));
    }
    let pick = |f: &dyn Fn(&GpuRun) -> f64| median(samples.iter().map(f).collect());
    Ok(Row {
        cube_radii: cube,
        block: 0,
        path: "gpu".into(),
        threads: rayon::current_num_threads(),
        wall: pick(&|s| s.0),
        grid: pick(&|s| s.1),
        blocks: 0.0,
        blocks_thread: 0.0,
        weld: pick(&|s| s.3),
        write: pick(&|s| s.4),
        gpu_ms: pick(&|s| s.2),
        vertices: samples[0].5,
        triangles: samples[0].6,
        speedup: 0.0,
        efficiency: 0.0,
    })
}

/// One panel per cube size: wall seconds against threads for each block size of the CPU path, the GPU path,
/// splashsurf, and the first CPU line's ideal scaling (its 1-thread wall ÷ threads).
fn scaling_panels(rows: &[Row]) -> Vec<crate::chart::Series<'static>> {
    let mut cubes: Vec<f32> = rows.iter().map(|r| r.cube_radii).collect();
    cubes.sort_by(f32::total_cmp);
    cubes.dedup();
    cubes
        .into_iter()
        .map(|cube| {
            let here: Vec<&Row> = rows.iter().filter(|r| r.cube_radii == cube).collect();
            let mut threads: Vec<usize> = here.iter().map(|r| r.threads).collect();
            threads.sort_unstable();
            threads.dedup();
            let name = |r: &Row| match r.path.as_str() {
                "cpu" => format!("meniscus, blocks of {}³", r.block),
                "gpu" => "meniscus --gpu".to_string(),
                other => other.to_string(),
            };
            let first_cpu = here.iter().find(|r| r.path == "cpu").map(|r| (r.block, r.threads, r.wall));
            let points = threads
                .iter()
                .map(|&t| {
                    let mut ys: Vec<(String, f64)> =
                        here.iter().filter(|r| r.threads == t).map(|r| (name(r), r.wall)).collect();
                    if let Some((_, t0, w0)) = first_cpu {
                        ys.push(("ideal (first line ÷ threads)".into(), w0 * t0 as f64 / t as f64));
                    }
                    (t as f64, ys)
                })
                .collect();
            crate::chart::Series {
                title: format!("cube {cube} r"),
                x_label: "threads",
                y_label: "wall s (median)",
                points,
            }
        })
        .collect()
}

/// The markdown table: one row per configuration; splashsurf's wall and our ratio to it beside our rows.
fn table(file: &Path, particles: usize, r: f32, cores: usize, rows: &[Row]) -> String {
    let mut s = format!(
        "mesh extraction of {} ({particles} particles, radius {r}) on {cores} cores; medians, seconds; efficiency = \
         thread time ÷ (wall × threads) of the block phase; the GPU rows' weld column is the host's block set-up, upload and copy of the indexed mesh (the GPU welds)\n\n| cube | block | path | threads | wall | grid | blocks | \
         blocks thread time | weld | write | speed-up | efficiency | splashsurf | ratio | triangles |\n\
         |---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
        file.display()
    );
    for row in rows.iter().filter(|x| x.path != "splashsurf") {
        let theirs =
            rows.iter().find(|x| x.path == "splashsurf" && x.cube_radii == row.cube_radii && x.threads == row.threads);
        let (ss, ratio) = match (theirs, row.path.as_str()) {
            (Some(x), "cpu") => (format!("{:.3}", x.wall), format!("{:.2}", row.wall / x.wall)),
            _ => ("–".into(), "–".into()),
        };
        let extra = if row.path == "gpu" { format!(" (GPU {:.1} ms)", row.gpu_ms) } else { String::new() };
        s.push_str(&format!(
            "| {} r | {} | {}{extra} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {} | {} | {ss} | {ratio} | {} |\n",
            row.cube_radii,
            if row.block > 0 { row.block.to_string() } else { "–".into() },
            row.path,
            row.threads,
            row.wall,
            row.grid,
            row.blocks,
            row.blocks_thread,
            row.weld,
            row.write,
            if row.path == "cpu" { format!("{:.2}", row.speedup) } else { "–".into() },
            if row.path == "cpu" { format!("{:.0} %", 100.0 * row.efficiency) } else { "–".into() },
            row.triangles
        ));
    }
    s
}
