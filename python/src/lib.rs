//! `meniscus._meniscus`: the native half of the Python package — thin wrappers of the library (no logic of the
//! CLI repeated): the renderer (`Renderer`), the simulation (`Simulation`), spray, foam and bubbles (`Diffuse`:
//! `meniscus::diffuse::generator::Live`), surface reconstruction (`Reconstructor`) and the loaders (`load`). Arrays arrive validated and C-contiguous from `meniscus/__init__.py`
//! and are read in place; the GIL is released while the GPU or the CPU extraction works; library errors become
//! `ValueError` (bad input), `OSError` (files) or `RuntimeError` (the device).

use std::collections::HashMap;
use std::sync::Arc;

use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::{PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use meniscus::device::{Gpu, GpuOptions};
use meniscus::renderer::{FrameRequest, Hooks, Renderer as Core, Upload};
use meniscus::scene::camera::Camera;
use meniscus::scene::{Bounds, Particles};
use meniscus::settings::Settings;
use meniscus::timing::PassTimes;
use meniscus::view::View;

/// A library error as the Python exception a user expects.
fn py_err(e: meniscus::Error) -> PyErr {
    use meniscus::Error as E;
    match e {
        E::Io { .. } => PyOSError::new_err(e.to_string()),
        E::Parse { .. } | E::Invalid(_) | E::Output { .. } | E::Limit(_) => PyValueError::new_err(e.to_string()),
        _ => PyRuntimeError::new_err(e.to_string()),
    }
}

/// Work moved to another thread's view of the GIL: the closure runs on this same thread while the GIL is
/// released (`Python::allow_threads`), so the unsendable objects it touches are never shared.
struct OnThisThread<T>(T);
// SAFETY: `allow_threads` runs the closure on the calling thread; the wrapped references never leave it.
unsafe impl<T> Send for OnThisThread<T> {}

impl<T> OnThisThread<T> {
    /// The wrapped value (a method call, so that a closure captures the whole wrapper, not its fields).
    fn into_inner(self) -> T {
        self.0
    }
}

thread_local! {
    /// One device per device filter, shared by the renderers and simulations of this thread.
    static DEVICES: std::cell::RefCell<HashMap<Option<String>, Arc<Gpu>>> = Default::default();
}

fn device(filter: Option<String>) -> PyResult<Arc<Gpu>> {
    DEVICES.with(|d| {
        if let Some(g) = d.borrow().get(&filter) {
            return Ok(g.clone());
        }
        let g = Gpu::new(&GpuOptions { device_filter: filter.clone(), ..Default::default() }).map_err(py_err)?;
        d.borrow_mut().insert(filter, g.clone());
        Ok(g)
    })
}

/// The preset, then the settings file over it; a key the file spells the deprecated way is a
/// DeprecationWarning.
fn settings(preset: &str, file: Option<&str>) -> PyResult<Settings> {
    let s = Settings::preset(preset).map_err(py_err)?;
    let Some(f) = file else { return Ok(s) };
    let mut notes = vec![];
    let s = s.with_toml_noting(std::path::Path::new(f), &mut notes).map_err(py_err)?;
    Python::with_gil(|py| {
        let kind = py.get_type::<pyo3::exceptions::PyDeprecationWarning>();
        notes.iter().try_for_each(|n| {
            let msg = std::ffi::CString::new(n.as_str()).unwrap_or_default();
            PyErr::warn(py, &kind, &msg, 1)
        })
    })?;
    Ok(s)
}

/// An N×3 float32 array's rows, copied (where the library keeps them); [`rows`] reads them in place.
fn points(a: &PyReadonlyArray2<f32>) -> PyResult<Vec<[f32; 3]>> {
    Ok(rows(a)?.to_vec())
}

fn camera(c: Option<([f32; 3], [f32; 3], f32)>) -> PyResult<Option<Camera>> {
    c.map(|(e, t, f)| Camera::new(e.into(), t.into(), f).map_err(py_err)).transpose()
}

/// The renderer: one per output size; `render` frames particles the way `meniscus render` frames a file.
/// Render one frame and wait for it: the final image (copied into host memory by the frame itself, into its
/// slot's kept read-back buffer) and the GPU time of each pass.
fn render_image(
    core: &mut Core,
    view: &View,
    s: &meniscus::settings::Settings,
    hooks: Hooks,
    count_work: bool,
) -> meniscus::Result<(image::RgbaImage, meniscus::timing::PassTimes)> {
    let req = FrameRequest::new(view, s).hooks(hooks).readback();
    let sub = core.submit(if count_work { req.count_work() } else { req })?;
    let img = core.read_submitted(sub)?;
    Ok((img, core.finish(sub)?))
}

#[pyclass(unsendable, module = "meniscus._meniscus")]
struct Renderer {
    core: Core,
    settings: Settings,
    size: (u32, u32),
    times: PassTimes,
    /// The last `render`'s host stages, ms.
    host: Vec<(String, f64)>,
    /// The particles (and the radius and isolated-particle settings they were set with) the renderer holds from the last
    /// `render` of an array: the same again are not set again (a turntable of one frame uploads it once).
    held: Option<(Particles, u32, meniscus::settings::IsolatedParams)>,
    /// The passes count their own work in the next frames (`work()`); off: the counting costs the frame.
    #[pyo3(get, set)]
    count_work: bool,
    /// Whether the last frame counted its work.
    counted: bool,
}

#[pymethods]
impl Renderer {
    #[new]
    #[pyo3(signature = (width, height, device=None, preset="default", settings_file=None))]
    fn new(
        width: u32,
        height: u32,
        device: Option<String>,
        preset: &str,
        settings_file: Option<&str>,
    ) -> PyResult<Self> {
        if width == 0 || height == 0 || width > 16384 || height > 16384 {
            return Err(PyValueError::new_err(format!("size {width}×{height} is out of range (1 … 16384 each)")));
        }
        let s = settings(preset, settings_file)?;
        let gpu = crate::device(device)?;
        let core = Core::new(&gpu).map_err(py_err)?;
        Ok(Renderer {
            core,
            settings: s,
            size: (width, height),
            times: PassTimes::default(),
            host: vec![],
            held: None,
            count_work: false,
            counted: false,
        })
    }

    /// Render particles; returns the image as H×W×4 RGBA bytes.
    /// `ids` seed each particle's noise (the `noise` pass), as a file's ids do in the CLI.
    /// `diffuse`: spray, foam and bubbles to draw with them (the `diffuse` effect).
    #[pyo3(signature = (positions, radius, camera=None, velocities=None, densities=None, ids=None, diffuse=None))]
    #[allow(clippy::too_many_arguments)]
    fn render<'py>(
        &mut self,
        py: Python<'py>,
        positions: PyReadonlyArray2<f32>,
        radius: f32,
        camera: Option<([f32; 3], [f32; 3], f32)>,
        velocities: Option<PyReadonlyArray2<f32>>,
        densities: Option<PyReadonlyArray1<f32>>,
        ids: Option<PyReadonlyArray1<i64>>,
        diffuse: Option<PyRef<'_, Diffuse>>,
    ) -> PyResult<Bound<'py, PyArray3<u8>>> {
        let t0 = std::time::Instant::now();
        let mut s = self.settings.clone();
        s.radius = radius;
        s.validate().map_err(py_err)?;
        let p = Particles {
            positions: points(&positions)?,
            velocities: velocities.as_ref().map(points).transpose()?,
            densities: densities.map(|d| d.as_array().to_vec()),
            ids: ids.map(|d| d.as_array().to_vec()),
            ..Default::default()
        };
        if p.ids.as_ref().is_some_and(|i| i.len() != p.positions.len()) {
            return Err(PyValueError::new_err("ids: one per particle"));
        }
        let bounds = meniscus::scene::percentile_bounds(&p.positions, 0.01)
            .ok_or_else(|| PyValueError::new_err("no finite positions"))?;
        let view = View::around(&bounds, crate::camera(camera)?, self.size.0, self.size.1, &s);
        view.camera.check().map_err(py_err)?;
        let drawn: &[meniscus::diffuse::Particle] = diffuse.as_ref().map_or(&[], |f| f.live.particles());
        let arrays = ms(t0);
        let key = (s.radius.to_bits(), s.isolated.clone());
        let held = self.held.as_ref().is_some_and(|(q, r, sp)| *r == key.0 && *sp == key.1 && *q == p);
        let work = OnThisThread((&mut self.core, &p, &view, &s, drawn));
        let count_work = self.count_work;
        let (img, times, upload, frame) = py
            .allow_threads(move || {
                let (core, p, view, s, diffuse) = work.into_inner();
                let t1 = std::time::Instant::now();
                if !held {
                    core.upload(Upload::scene(p, s))?;
                }
                if !diffuse.is_empty() || core.state().particles().diffuse_count() > 0 {
                    core.upload(Upload::Diffuse { particles: diffuse, settings: s })?;
                }
                let upload = ms(t1);
                let t2 = std::time::Instant::now();
                let (img, times) = render_image(core, view, s, Hooks::default(), count_work)?;
                Ok::<_, meniscus::Error>((img, times, upload, ms(t2)))
            })
            .map_err(py_err)?;
        if !held {
            self.held = Some((p, key.0, key.1));
        }
        self.times = times;
        self.counted = count_work;
        let t3 = std::time::Instant::now();
        let out = image_array(py, img);
        let h = self.core.state().host_times();
        let before = h.total();
        self.host = vec![
            ("arrays".into(), arrays),
            ("upload".into(), upload),
            ("prepare".into(), h.prepare),
            ("slot_wait".into(), h.slot_wait),
            ("stage".into(), h.stage),
            ("record".into(), h.record),
            ("submit".into(), h.submit),
            ("wait_and_readback".into(), (frame - before).max(0.0)),
            ("to_numpy".into(), ms(t3)),
        ];
        out
    }

    /// Render a simulation's particles where they are, on the device (copied on the GPU, never through the
    /// host); its container's walls are the background.
    #[pyo3(signature = (sim, camera=None))]
    fn render_sim<'py>(
        &mut self,
        py: Python<'py>,
        sim: &Simulation,
        camera: Option<([f32; 3], [f32; 3], f32)>,
    ) -> PyResult<Bound<'py, PyArray3<u8>>> {
        if !Arc::ptr_eq(&sim.gpu, self.core.state().gpu()) {
            return Err(PyValueError::new_err("the simulation runs on another device than this renderer"));
        }
        let mut s = self.settings.clone();
        s.radius = sim.core.radius();
        s.validate().map_err(py_err)?;
        // The simulation's particles replace any array's.
        self.held = None;
        let (lo, hi) = sim.core.scene.container;
        let mut view = View::around(&Bounds { lo, hi }, crate::camera(camera)?, self.size.0, self.size.1, &s);
        view.env.boxes = sim.core.scene.wall_boxes();
        view.env.ground_y = lo.y;
        let n = sim.core.count();
        let src = sim.core.particle_buffer();
        let first = sim.core.frames == 0;
        let initial = if first { Some(sim.core.read().map_err(py_err)?) } else { None };
        let work = OnThisThread((&mut self.core, &view, &s, src, initial));
        let count_work = self.count_work;
        let (img, times) = py
            .allow_threads(move || {
                let (core, view, s, src, initial) = work.into_inner();
                match initial {
                    // Not stepped yet: the scene's initial particles, from the host.
                    Some(p) => {
                        core.upload(Upload::points(&p.positions))?;
                        render_image(core, view, s, Hooks::default(), count_work)
                    }
                    None => {
                        core.upload(Upload::Gpu { count: n, bounds: (lo, hi), diffuse_slots: 0 })?;
                        let copy = |ctx: &mut meniscus::device::FrameCtx, out: &meniscus::device::Buffer| {
                            let size = n as u64 * meniscus::shader_constants::BYTES_PER_PARTICLE;
                            let region = ash::vk::BufferCopy { src_offset: 0, dst_offset: 0, size };
                            ctx.copy_buffer(src, out, region);
                        };
                        render_image(core, view, s, Hooks { produce: Some(&copy), ..Default::default() }, count_work)
                    }
                }
            })
            .map_err(py_err)?;
        self.times = times;
        self.counted = count_work;
        image_array(py, img)
    }

    /// The last frame's depth (linear eye depth, +inf = no fluid), view-space normals and thickness.
    fn buffers<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let t = self.core.state().targets().ok_or_else(|| PyRuntimeError::new_err("nothing rendered yet"))?;
        let state = self.core.state();
        let d = PyDict::new(py);
        let img2 = |img: &meniscus::device::Image| -> PyResult<Bound<'py, PyArray2<f32>>> {
            let data = state.read_f32(img).map_err(py_err)?;
            let (w, h) = (img.extent.width as usize, img.extent.height as usize);
            PyArray1::from_vec(py, data).reshape([h, w])
        };
        let smoothed = self.core.state().smoothed_depth().unwrap_or(&t.depth);
        d.set_item("depth", img2(smoothed)?)?;
        d.set_item("thickness", img2(&t.thickness)?)?;
        let raw = state.read_image(&t.normals).map_err(py_err)?;
        let words: Vec<u32> = raw.chunks_exact(4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
        let mut n = Vec::with_capacity(words.len() * 3);
        for w in words {
            n.extend_from_slice(&if w == 0 { [0.0; 3] } else { meniscus::renderer::unpack_normal(w) });
        }
        let (w, h) = (t.normals.extent.width as usize, t.normals.extent.height as usize);
        d.set_item("normals", PyArray1::from_vec(py, n).reshape([h, w, 3])?)?;
        Ok(d)
    }

    /// The last frame's GPU time of each pass, in milliseconds, in the frame's order.
    fn timings(&self) -> Vec<(String, f64)> {
        self.times.0.clone()
    }

    /// Each pass's own count of its work in the last frame (`meniscus bench`'s "Work per pass"): per pass
    /// ("splat", "iso", "iso_volume", "noise") a dict of its counters, or None where the pass did not run.
    fn work<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        if !self.counted {
            return Err(PyValueError::new_err(
                "the last frame did not count its work: set Renderer.count_work = True before rendering it",
            ));
        }
        let ran = |pass: &str| self.times.0.iter().any(|(n, _)| n == pass);
        let w = self.core.state().work(&self.settings, ran).map_err(py_err)?;
        let d = PyDict::new(py);
        let counts = |pairs: &[(&str, u64)]| -> PyResult<Bound<'py, PyDict>> {
            let e = PyDict::new(py);
            for (k, v) in pairs {
                e.set_item(*k, *v)?;
            }
            Ok(e)
        };
        let splat = w.splat.map(|s| counts(&[("tests", s.tests), ("spheres", s.spheres), ("tiles_skipped", s.tiles_skipped)]));
        let iso = w.iso.map(|s| counts(&[("samples", s.samples), ("queued", s.queued), ("fallbacks", s.fallbacks), ("tiles", s.tiles)]));
        let vol = w.iso_volume.map(|s| counts(&[("deposits", s.deposits), ("atomics", s.atomics)]));
        let noise = w.noise.map(|s| {
            counts(&[
                ("level", s.level as u64),
                ("texels", s.texels),
                ("sprites", s.sprites),
                ("evaluated", s.evaluated),
                ("skipped", s.skipped),
                ("binned", s.binned),
                ("longest", s.longest),
            ])
        });
        d.set_item("splat", splat.transpose()?)?;
        d.set_item("iso", iso.transpose()?)?;
        d.set_item("iso_volume", vol.transpose()?)?;
        d.set_item("noise", noise.transpose()?)?;
        Ok(d)
    }

    /// The last `render` of an array's host stages, in milliseconds: the arrays read and the camera framed,
    /// the particles set, the renderer's own stages (as `meniscus bench` reports them), the wait for the GPU
    /// with the image's copy out of the frame's read-back buffer, and the NumPy array made of it.
    fn host_timings(&self) -> Vec<(String, f64)> {
        self.host.clone()
    }
}

/// Milliseconds since `t`.
fn ms(t: std::time::Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

fn image_array(py: Python<'_>, img: image::RgbaImage) -> PyResult<Bound<'_, PyArray3<u8>>> {
    let (w, h) = (img.width() as usize, img.height() as usize);
    img.into_raw().into_pyarray(py).reshape([h, w, 4])
}

/// The live GPU simulation (Position Based Fluids) of a built-in scene.
#[pyclass(unsendable, module = "meniscus._meniscus")]
struct Simulation {
    core: meniscus::sim::Simulation,
    gpu: Arc<Gpu>,
}

#[pymethods]
impl Simulation {
    #[new]
    #[pyo3(signature = (scene, particles=None, device=None, settings_file=None, solver=None, adaptive_step=None))]
    fn new(
        scene: &str,
        particles: Option<usize>,
        device: Option<String>,
        settings_file: Option<&str>,
        solver: Option<&str>,
        adaptive_step: Option<bool>,
    ) -> PyResult<Self> {
        // A built-in scene, or a SPlisHSPlasH scene file (its radius, blocks, container, gravity, fps, viscosity).
        let (sc, file) = meniscus::sim::scene_file::resolve(scene, particles).map_err(py_err)?;
        let mut params = settings("default", settings_file)?.sim;
        if let Some(f) = &file {
            f.apply(&mut params);
            for w in &f.warnings {
                eprintln!("warning: {w}");
            }
        }
        // The pressure solver (`[sim] solver` of the settings file otherwise).
        if let Some(name) = solver {
            params.solver = meniscus::named::from_name::<meniscus::sim::params::Solver>(name)
                .map_err(|e| PyValueError::new_err(format!("solver {name:?}: {e}")))?;
        }
        // The step re-chosen every frame (`[sim] adaptive_step`, a scene file's cflMethod otherwise).
        if let Some(a) = adaptive_step {
            params.adaptive_step = a;
        }
        params.validate().map_err(py_err)?;
        let gpu = crate::device(device)?;
        let core = meniscus::sim::Simulation::new(&gpu, sc, params).map_err(py_err)?;
        Ok(Simulation { core, gpu })
    }

    /// Simulate `n` frames (each `substeps` steps), releasing the GIL meanwhile.
    #[pyo3(signature = (n=1))]
    fn step(&mut self, py: Python<'_>, n: u32) -> PyResult<()> {
        let work = OnThisThread(&mut self.core);
        py.allow_threads(move || {
            let core = work.into_inner();
            for _ in 0..n {
                core.step_frame()?;
            }
            Ok(())
        })
        .map_err(py_err)
    }

    /// Particle positions (N×3 float32), in the order of the last step.
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let p = self.core.read_positions().map_err(py_err)?;
        vec3_array(py, p)
    }

    /// Particle velocities (N×3 float32), in the order of the last step.
    fn velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let p = self.core.read().map_err(py_err)?;
        vec3_array(py, p.velocities.unwrap_or_default())
    }

    /// Particle ids (int64), in the order of the last step.
    fn ids<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let p = self.core.read().map_err(py_err)?;
        Ok(p.ids.unwrap_or_default().into_pyarray(py))
    }

    /// Particles simulated.
    #[getter]
    fn count(&self) -> u32 {
        self.core.count()
    }

    /// Particles the emitter has recycled since the start (a scene file's `emitterReuseParticles`).
    #[getter]
    fn reused(&self) -> u64 {
        self.core.reused()
    }

    /// Steps of the last frame (with the adaptive step, chosen per frame).
    #[getter]
    fn substeps(&self) -> u32 {
        self.core.constants.substeps
    }

    /// The largest particle speed (m/s) of the last frame; None before the first.
    #[getter]
    fn last_speed(&self) -> Option<f32> {
        self.core.last_speed()
    }

    /// The pressure solver ("pbf" or "dfsph").
    #[getter]
    fn solver(&self) -> &'static str {
        self.core.params.solver.name()
    }

    /// DFSPH: what its two solves did over the last frame (a dict per solve: steps, corrections,
    /// max_corrections, last_error, max_error, mean_error — fractions of ρ0 — and unconverged); None for PBF or
    /// before the first frame.
    fn solver_stats<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(st) = self.core.solver_stats().map_err(py_err)? else { return Ok(None) };
        let d = PyDict::new(py);
        for (name, s) in [("density", st.density), ("divergence", st.divergence)] {
            let e = PyDict::new(py);
            e.set_item("steps", s.steps)?;
            e.set_item("corrections", s.corrections)?;
            e.set_item("max_corrections", s.max_corrections)?;
            e.set_item("last_error", s.last_error)?;
            e.set_item("max_error", s.max_error)?;
            e.set_item("mean_error", s.mean_error)?;
            e.set_item("unconverged", s.unconverged)?;
            d.set_item(name, e)?;
        }
        Ok(Some(d))
    }

    /// The particle radius (m).
    #[getter]
    fn radius(&self) -> f32 {
        self.core.radius()
    }

    /// Frames simulated so far.
    #[getter]
    fn frames(&self) -> u64 {
        self.core.frames
    }
}

fn vec3_array(py: Python<'_>, v: Vec<[f32; 3]>) -> PyResult<Bound<'_, PyArray2<f32>>> {
    let n = v.len();
    let flat: Vec<f32> = v.into_iter().flatten().collect();
    flat.into_pyarray(py).reshape([n, 3])
}

/// A mesh as arrays: vertices, triangles, normals, and the vertices' velocities when asked for.
type MeshArrays<'py> = (
    Bound<'py, PyArray2<f32>>,
    Bound<'py, PyArray2<u32>>,
    Bound<'py, PyArray2<f32>>,
    Option<Bound<'py, PyArray2<f32>>>,
);

/// A surface reconstructor for simulators: the iso surface of particles as a mesh — `meniscus mesh`'s
/// (surface::mesh::reconstruct_field) — with its parameters fixed, and on the GPU its device, pipelines and
/// buffers kept between calls (`compute::mc::Mc` keeps the case table and grows its scratch buffers), so a call
/// pays for the extraction and its transfers, not for their set-up. Positions are read from the numpy array in
/// place (C-contiguous float32, as `meniscus/__init__.py` hands them over), without a copy.
#[pyclass(unsendable, module = "meniscus._meniscus")]
struct Reconstructor {
    recon: meniscus::surface::mesh::Reconstruct,
    dev: Option<(Arc<Gpu>, meniscus::compute::mc::Mc)>,
}

#[pymethods]
impl Reconstructor {
    #[new]
    #[pyo3(signature = (radius, support, cube, threshold, smoothing_iters, gpu, device=None))]
    fn new(
        radius: f32,
        support: f32,
        cube: f32,
        threshold: f32,
        smoothing_iters: u32,
        gpu: bool,
        device: Option<String>,
    ) -> PyResult<Self> {
        use meniscus::field::{extract::ExtractParams, smooth::SmoothParams};
        let recon = meniscus::surface::mesh::Reconstruct {
            support: support * radius,
            extract: ExtractParams::new(cube * radius, threshold),
            smoothing: SmoothParams { iterations: smoothing_iters, ..Default::default() },
        };
        let dev = if gpu {
            let g = crate::device(device)?;
            let mc = meniscus::compute::mc::Mc::new(&g).map_err(py_err)?;
            Some((g, mc))
        } else {
            None
        };
        Ok(Reconstructor { recon, dev })
    }

    /// The mesh of `positions` (N×3): vertices, triangles, normals, and with `velocities` (N×3) their SPH
    /// interpolation at the vertices.
    #[pyo3(signature = (positions, velocities=None))]
    fn reconstruct<'py>(
        &self,
        py: Python<'py>,
        positions: PyReadonlyArray2<'py, f32>,
        velocities: Option<PyReadonlyArray2<'py, f32>>,
    ) -> PyResult<MeshArrays<'py>> {
        let pts = rows(&positions)?;
        let vel = velocities.as_ref().map(rows).transpose()?;
        if vel.is_some_and(|v| v.len() != pts.len()) {
            return Err(PyValueError::new_err("velocities: expected one row per particle"));
        }
        let work = OnThisThread((pts, &self.recon, self.dev.as_ref(), vel));
        let (m, mv) = py
            .allow_threads(move || {
                let (pts, r, dev, vel) = work.into_inner();
                let rec = meniscus::surface::mesh::reconstruct_field(pts, r, dev.map(|(g, mc)| (g, mc)))?;
                let mv = vel.map(|v| rec.at_vertices(v));
                Ok::<_, meniscus::Error>((rec.mesh, mv))
            })
            .map_err(py_err)?;
        let tris: Vec<u32> = m.triangles.iter().flatten().copied().collect();
        let nt = m.triangles.len();
        Ok((
            vec3_array(py, m.vertices)?,
            tris.into_pyarray(py).reshape([nt, 3])?,
            vec3_array(py, m.normals)?,
            mv.map(|v| vec3_array(py, v)).transpose()?,
        ))
    }

    /// The device it extracts on (None: the CPU).
    fn device_name(&self) -> Option<String> {
        self.dev.as_ref().map(|(g, _)| g.info.name.clone())
    }

    /// Bytes of device memory it keeps between calls.
    fn kept_bytes(&self) -> u64 {
        self.dev.as_ref().map_or(0, |(_, mc)| mc.kept_bytes())
    }
}

/// An N×3 float32 array's rows in place (no copy): C-contiguous, as `meniscus/__init__.py` makes them.
fn rows<'a>(a: &'a PyReadonlyArray2<'_, f32>) -> PyResult<&'a [[f32; 3]]> {
    let s = a.as_slice().map_err(|_| PyValueError::new_err("expected a C-contiguous N×3 float32 array"))?;
    if s.len() % 3 != 0 {
        return Err(PyValueError::new_err("expected an N×3 array"));
    }
    Ok(bytemuck::cast_slice(s))
}

/// Edge vertex pairs (E×2) and each corner's edge (3M).
type EdgeArrays<'py> = (Bound<'py, PyArray2<u32>>, Bound<'py, PyArray1<u32>>);

/// A triangle mesh's edges as Blender stores them: every distinct edge once (vertex pairs, in the order of their
/// sorted keys) and, per corner of each triangle, the edge from that corner to the next.
#[pyfunction]
fn mesh_edges<'py>(py: Python<'py>, triangles: PyReadonlyArray2<u32>) -> PyResult<EdgeArrays<'py>> {
    let t = triangles.as_slice().map_err(|_| PyValueError::new_err("expected a C-contiguous M×3 uint32 array"))?;
    if t.len() % 3 != 0 || t.len() / 3 > (u32::MAX / 3) as usize {
        return Err(PyValueError::new_err("triangles: expected an M×3 array"));
    }
    let tris: Vec<[u32; 3]> = t.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let (edges, corner_edge) = py.allow_threads(move || meniscus::field::extract::mesh_edges(&tris));
    let edges: Vec<u32> = edges.into_iter().flatten().collect();
    let ne = edges.len() / 2;
    Ok((edges.into_pyarray(py).reshape([ne, 2])?, corner_edge.into_pyarray(py)))
}

/// The Vulkan device the package renders and meshes on (`device`: a part of its name, else the best one):
/// its name, driver, Vulkan version and type. RuntimeError when there is no Vulkan loader or device.
#[pyfunction]
#[pyo3(signature = (device=None))]
fn device_info<'py>(py: Python<'py>, device: Option<String>) -> PyResult<Bound<'py, PyDict>> {
    let g = crate::device(device)?;
    let d = PyDict::new(py);
    d.set_item("name", &g.info.name)?;
    d.set_item("driver", &g.info.driver)?;
    d.set_item("api_version", &g.info.api_version)?;
    d.set_item("device_type", &g.info.device_type)?;
    Ok(d)
}

/// A USD stage being written (`meniscus::export::usd::UsdWriter`): frames added in time order, then `finish`.
#[pyclass(unsendable, module = "meniscus._meniscus")]
struct UsdStage {
    writer: Option<meniscus::export::usd::UsdWriter>,
}

fn rows_u32(a: &PyReadonlyArray2<u32>) -> PyResult<Vec<[u32; 3]>> {
    let s = a.as_slice().map_err(|_| PyValueError::new_err("expected a C-contiguous M×3 uint32 array"))?;
    Ok(s.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
}

#[pymethods]
impl UsdStage {
    #[new]
    #[pyo3(signature = (path, fps, meters_per_unit=1.0, diffuse=false))]
    fn new(path: &str, fps: f64, meters_per_unit: f64, diffuse: bool) -> PyResult<Self> {
        let w = meniscus::export::usd::UsdWriter::create(
            std::path::Path::new(path),
            fps,
            meters_per_unit,
            diffuse,
            "meniscus (Python)",
        )
        .map_err(py_err)?;
        Ok(UsdStage { writer: Some(w) })
    }

    fn add_mesh(
        &mut self,
        time: f64,
        vertices: PyReadonlyArray2<f32>,
        triangles: PyReadonlyArray2<u32>,
        normals: PyReadonlyArray2<f32>,
        velocities: PyReadonlyArray2<f32>,
    ) -> PyResult<()> {
        let w = self.writer.as_mut().ok_or_else(|| PyValueError::new_err("the stage is finished"))?;
        let (v, t, n, vel) = (points(&vertices)?, rows_u32(&triangles)?, points(&normals)?, points(&velocities)?);
        if n.len() != v.len() || vel.len() != v.len() {
            return Err(PyValueError::new_err("normals and velocities: one row per vertex"));
        }
        if t.iter().flatten().any(|&i| i as usize >= v.len()) {
            return Err(PyValueError::new_err("triangles: a vertex index is out of range"));
        }
        w.add_mesh(time, &v, &n, &t, &vel).map_err(py_err)
    }

    fn add_points(
        &mut self,
        time: f64,
        positions: PyReadonlyArray2<f32>,
        velocities: PyReadonlyArray2<f32>,
        widths: PyReadonlyArray1<f32>,
        kinds: PyReadonlyArray1<i32>,
    ) -> PyResult<()> {
        let w = self.writer.as_mut().ok_or_else(|| PyValueError::new_err("the stage is finished"))?;
        let (p, v) = (points(&positions)?, points(&velocities)?);
        let (wd, k) = (widths.as_slice()?.to_vec(), kinds.as_slice()?.to_vec());
        if v.len() != p.len() || wd.len() != p.len() || k.len() != p.len() {
            return Err(PyValueError::new_err("velocities, widths and kinds: one per point"));
        }
        let frame = meniscus::export::usd::PointsFrame { positions: &p, velocities: &v, widths: &wd, kinds: &k };
        w.add_points(time, &frame).map_err(py_err)
    }

    fn finish(&mut self) -> PyResult<()> {
        let w = self.writer.take().ok_or_else(|| PyValueError::new_err("the stage is finished"))?;
        w.finish().map_err(py_err)
    }
}

/// The SPH iso-surface of particles as an OpenVDB file: the narrow-band level set `surface` (and with `fog` the
/// field as the fog volume `density`), on the marching-cubes lattice of `cube` radii — `meniscus mesh --out
/// X.vdb`'s. Returns the level set's active voxel count.
#[pyfunction]
#[pyo3(signature = (path, positions, radius, support, cube, threshold, half_width=3.0, fog=false))]
#[allow(clippy::too_many_arguments)]
fn write_vdb(
    py: Python<'_>,
    path: &str,
    positions: PyReadonlyArray2<f32>,
    radius: f32,
    support: f32,
    cube: f32,
    threshold: f32,
    half_width: f32,
    fog: bool,
) -> PyResult<u64> {
    use meniscus::field::{extract::ExtractParams, smooth::SmoothParams};
    let pts = points(&positions)?;
    if !(half_width.is_finite() && (1.0..=32.0).contains(&half_width)) {
        return Err(PyValueError::new_err("half_width must be in [1, 32] voxels"));
    }
    let r = meniscus::surface::mesh::Reconstruct {
        support: support * radius,
        extract: ExtractParams::new(cube * radius, threshold),
        smoothing: SmoothParams { iterations: 0, ..Default::default() },
    };
    let path = std::path::PathBuf::from(path);
    py.allow_threads(move || {
        let rec = meniscus::surface::mesh::reconstruct_field(&pts, &r, None)?;
        meniscus::export::vdb::write_surface(&path, &rec, half_width, fog)
    })
    .map_err(py_err)
}

/// A particle sequence as the CLI resolves it (a pattern with {}, a folder, a glob, a .pvd, or one file of a
/// numbered sequence): its frames (number, path), and the particle radius and frame rate the CLI would use —
/// a SPlisHSPlasH scene.json beside the files, else the radius estimated from the first non-empty frame.
#[pyfunction]
fn sequence<'py>(py: Python<'py>, spec: &str) -> PyResult<Bound<'py, PyDict>> {
    use meniscus::scene::sequence;
    let mut frames = sequence::resolve_all(spec).map_err(py_err)?;
    if frames.len() == 1 {
        // One file of a numbered sequence: its siblings.
        if let Some(pat) = sequence::numbered_pattern(&frames[0].path) {
            if let Ok(all) = sequence::resolve_all(&pat) {
                if all.len() > 1 {
                    frames = all;
                }
            }
        }
    }
    let scene = meniscus::scene::splishsplash::SceneJson::find_for(&frames[0].path).map_err(py_err)?;
    let (radius, from) = match scene.as_ref().and_then(|s| s.radius) {
        Some(r) => (Some(r), "scene.json"),
        None => {
            let mut r = None;
            for f in frames.iter().take(8) {
                let p = meniscus::scene::load_with(&f.path, &Default::default()).map_err(py_err)?;
                if !p.positions.is_empty() {
                    r = meniscus::scene::estimate_radius(&p.positions);
                    break;
                }
            }
            (r, "estimated")
        }
    };
    let d = PyDict::new(py);
    let list: Vec<(u64, String)> = frames.iter().map(|f| (f.number, f.path.to_string_lossy().into_owned())).collect();
    d.set_item("frames", list)?;
    d.set_item("radius", radius)?;
    d.set_item("radius_from", from)?;
    d.set_item("fps", scene.as_ref().and_then(|s| s.fps))?;
    Ok(d)
}

/// Read a particle file of any format the CLI reads: positions (N×3 float32) and every per-particle array by
/// name (float64; vectors N×3).
#[pyfunction]
fn load<'py>(py: Python<'py>, path: &str) -> PyResult<Bound<'py, PyDict>> {
    let raw = {
        let p = std::path::Path::new(path);
        let bytes = meniscus::input::read(p).map_err(py_err)?;
        let f = meniscus::scene::detect_format(p, &bytes)
            .ok_or_else(|| PyValueError::new_err(format!("{path}: byte 0: unknown particle format")))?;
        meniscus::scene::parse_raw(f, p, &bytes).map_err(py_err)?
    };
    let d = PyDict::new(py);
    let n = raw.positions.len();
    d.set_item("positions", vec3_array(py, raw.positions)?)?;
    for a in raw.arrays {
        if a.components == 0 || a.data.len() != n * a.components {
            continue;
        }
        let arr = a.data.into_pyarray(py);
        if a.components == 1 {
            d.set_item(a.name, arr)?;
        } else {
            d.set_item(a.name, arr.reshape([n, a.components])?)?;
        }
    }
    Ok(d)
}

/// Built-in simulation scenes: (name, default particle count, description).
#[pyfunction]
fn sim_scenes() -> Vec<(&'static str, usize, &'static str)> {
    meniscus::sim::scene::SCENES.to_vec()
}

/// Spray, foam and bubbles of a simulation stepped by the caller (`meniscus::diffuse::generator::Live`: Ihmsen et al. 2012,
/// its limits calibrated as the run goes).
#[pyclass(unsendable, module = "meniscus._meniscus")]
struct Diffuse {
    live: meniscus::diffuse::generator::Live,
    radius: f32,
}

#[pymethods]
impl Diffuse {
    #[new]
    #[pyo3(signature = (radius, fps, settings_file=None))]
    fn new(radius: f32, fps: f32, settings_file: Option<&str>) -> PyResult<Self> {
        if !(radius.is_finite() && radius > 0.0 && fps.is_finite() && fps > 0.0) {
            return Err(PyValueError::new_err("particle_radius and fps must be positive numbers"));
        }
        let params = settings("default", settings_file)?.diffuse;
        meniscus::section::Section::check(&params).map_err(|(_, reason)| PyValueError::new_err(reason))?;
        Ok(Diffuse { live: meniscus::diffuse::generator::Live::new(&params, fps), radius })
    }

    /// The next frame of fluid (positions and velocities N×3, ids N or None: the index); releases the GIL.
    #[pyo3(signature = (positions, velocities, ids=None))]
    fn step(
        &mut self,
        py: Python<'_>,
        positions: PyReadonlyArray2<f32>,
        velocities: PyReadonlyArray2<f32>,
        ids: Option<PyReadonlyArray1<i64>>,
    ) -> PyResult<(usize, usize)> {
        let p = Particles {
            positions: points(&positions)?,
            velocities: Some(points(&velocities)?),
            ids: ids.map(|d| d.as_array().to_vec()),
            ..Default::default()
        };
        if p.ids.as_ref().is_some_and(|i| i.len() != p.positions.len()) {
            return Err(PyValueError::new_err("ids: one per particle"));
        }
        let work = OnThisThread((&mut self.live, &p, self.radius));
        let stats = py.allow_threads(move || {
            let (live, p, r) = work.into_inner();
            live.step(p, r)
        });
        Ok((stats.spawned, stats.died))
    }

    /// The living particles as arrays: positions, velocities (N×3 float32), lifetime, age (float32), kind
    /// (uint8: 0 foam, 1 spray, 2 bubbles), id and source (uint32).
    fn particles<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let ps = self.live.particles();
        let d = PyDict::new(py);
        d.set_item("positions", vec3_array(py, ps.iter().map(|p| p.position.to_array()).collect())?)?;
        d.set_item("velocities", vec3_array(py, ps.iter().map(|p| p.velocity.to_array()).collect())?)?;
        d.set_item("lifetime", ps.iter().map(|p| p.lifetime).collect::<Vec<f32>>().into_pyarray(py))?;
        d.set_item("age", ps.iter().map(|p| p.age).collect::<Vec<f32>>().into_pyarray(py))?;
        d.set_item("kind", ps.iter().map(|p| p.kind as u8).collect::<Vec<u8>>().into_pyarray(py))?;
        d.set_item("id", ps.iter().map(|p| p.id).collect::<Vec<u32>>().into_pyarray(py))?;
        d.set_item("source", ps.iter().map(|p| p.source).collect::<Vec<u32>>().into_pyarray(py))?;
        Ok(d)
    }

    /// Living particles of each kind: (foam, spray, bubbles).
    fn counts(&self) -> (usize, usize, usize) {
        let [a, b, c] = self.live.counts();
        (a, b, c)
    }
}

#[pymodule]
fn _meniscus(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Renderer>()?;
    m.add_class::<Diffuse>()?;
    m.add_class::<Simulation>()?;
    m.add_class::<Reconstructor>()?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(device_info, m)?)?;
    m.add_function(wrap_pyfunction!(write_vdb, m)?)?;
    m.add_function(wrap_pyfunction!(sequence, m)?)?;
    m.add_function(wrap_pyfunction!(mesh_edges, m)?)?;
    m.add_class::<UsdStage>()?;
    m.add_function(wrap_pyfunction!(sim_scenes, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
