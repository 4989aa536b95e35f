//! `meniscus demo`: a window (winit + Vulkan swapchain) that plays a particle sequence, a built-in scene or a
//! file through the renderer. The renderer draws offscreen exactly as `render` does; the demo only blits the
//! result (plus a text overlay) into the swapchain image. Keys and mouse: see [`HELP`].
//!
//! Frame loop, with the renderer's frames in flight (2): wait for the frame two back (the only host wait),
//! write this slot's overlay staging and values, acquire (a semaphore, no fence), submit ONE command buffer —
//! overlay upload, every pass, the view and overlay passes, the blit into the swapchain image — that waits for
//! the acquire and signals the image's render-finished semaphore, then present. GPU times shown are those of
//! the frame the slot ran before (read a frame late, without a query wait). Parts: `controller` (camera control,
//! pure functions), `playback` (frame source and stepping), `overlay` (text), `present` (swapchain); this module
//! holds the window loop and the keys.

mod controller;
mod draw;
mod keys;
pub(crate) mod overlay;
mod playback;
mod present;

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use ash::vk;
use glam::Vec3;
use gpu_allocator::MemoryLocation;
use raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, ModifiersState, PhysicalKey};
use winit::window::{Window, WindowId};

use meniscus::device::Binary;
use meniscus::device::{Buffer, FrameCtx, Gpu, GpuOptions, Image};
use meniscus::inspect::Inspector;
use meniscus::named::Filter;
use meniscus::renderer::{Backdrop, FrameImages, FrameRequest, Hooks, Renderer, Upload};
use meniscus::scene::camera::Camera;
use meniscus::scene::{LoadOptions, Particles};
use meniscus::settings::{Settings, Surface};
use meniscus::timing::PassTimes;
use meniscus::view::Environment;
use meniscus::view::View;
use meniscus::view::ViewMode;
use meniscus::{Error, Result, VkContext};

use crate::args::{GpuArgs, LoadArgs, SceneArgs, SettingsArgs};
use crate::job::{Job, Select};
use clap::Args;

/// Every key, for `--help` and the on-screen help (H).
pub const HELP: &str = "\
mouse: left drag orbit | right drag (or shift+left) pan | wheel zoom
W A S D / Q E: fly forward, left, back, right / down, up | R: reset camera
C: print the camera as a --camera argument (stdout)
Space: play/pause | Left/Right: step a frame | Up/Down: speed x2 / /2 | L: loop
1 final | 2 raw depth | 3 smoothed depth | 4 thickness | 5 normals | 6 SSR | 7 particles
B: particle colour by speed / density / height
F: next filter | I: spheres / iso-surface / mesh | G: fluid scale 1 / 0.5 / 0.25 | X: SSR on/off | N: noise (waves, whitecaps) on/off | O: next preset
K: spray, foam and bubbles (diffuse particles) on/off
V: vsync on/off | P: screenshot (PNG) | M: record a movie on/off (--record FILE, else meniscus-recording-NNNN.mp4) | H: help on/off | Esc: quit
--sim: Space pause | Right: one frame | Backspace: restart | hold Ctrl + move the mouse: push the water";

/// `meniscus demo`.
#[derive(Args, Clone, Debug)]
pub struct DemoArgs {
    #[command(flatten)]
    scene: SceneArgs,
    #[arg(long, default_value_t = 1280)]
    width: u32,
    #[arg(long, default_value_t = 720)]
    height: u32,
    #[command(flatten)]
    set: SettingsArgs,
    /// Playback rate of a sequence in frames per second (before the speed factor).
    #[arg(long, value_parser = crate::args::finite::<f32>, allow_negative_numbers = true, default_value_t = 25.0)]
    fps: f32,
    /// Present without vsync (IMMEDIATE or MAILBOX when the driver has them).
    #[arg(long)]
    no_vsync: bool,
    /// Scripted run: draw this many frames, then exit.
    #[arg(long)]
    frames: Option<u64>,
    /// With --frames: write the last frame here (PNG).
    #[arg(long)]
    screenshot: Option<PathBuf>,
    /// Record the window into this movie (.mp4, .webm or .gif, through ffmpeg) from the start; M stops and
    /// starts recording (one frame per drawn frame, played back at --fps).
    #[arg(long, value_name = "MOVIE")]
    record: Option<PathBuf>,
    /// With --frames: resize the window to ¾ after a third of the frames and back after two thirds (tests the
    /// swapchain's recreation with frames in flight).
    #[arg(long, hide = true)]
    exercise_resize: bool,
    /// Play a live simulation of this scene instead of a file: dambreak, drop, waterfall or pool (`--particles`
    /// sets the count; the `[sim]` settings section the solver), or a SPlisHSPlasH scene.json (its particles,
    /// container, colliders, gravity and viscosity). Keys: Space pause, → one frame, Backspace
    /// restart, hold Ctrl and move the mouse to push the water with a sphere.
    #[arg(long, value_name = "SCENE")]
    sim: Option<String>,
    /// Split each frame over the main and the async compute queue (the simulation step, background and
    /// thickness on the async queue, beside the previous frame's fluid passes): auto = on when the device has a
    /// queue for it, on, off.
    #[arg(long = "async", value_parser = ["auto", "on", "off"], default_value = "auto")]
    async_mode: String,
    #[command(flatten)]
    load: LoadArgs,
    #[command(flatten)]
    gpu: GpuArgs,
}

/// `meniscus demo`: the shared [`Job`], then the window.
pub fn main(a: &DemoArgs) -> anyhow::Result<()> {
    if a.screenshot.is_some() && a.frames.is_none() {
        anyhow::bail!("--screenshot needs --frames N (or press P in the window)");
    }
    crate::args::check_size(a.width, a.height)?;
    if let Some(p) = &a.record {
        let kind = crate::args::out_kind("--record", p, &crate::movie::MOVIE_KINDS)?;
        crate::args::check_out("--record", p, kind)?;
    }
    let settings = a.set.resolve()?;
    let (sim, job) = match &a.sim {
        Some(name) => {
            let (mut scene, file) = meniscus::sim::scene_file::resolve(name, a.scene.particles)?;
            for w in file.iter().flat_map(|f| &f.warnings) {
                eprintln!("warning: {w}");
            }
            // The background mesh (read once, for the job too) is also a collider of the live water — when it can
            // be one (scenery outside the tank, or one too fine for the lattice, is still drawn).
            let mesh =
                a.scene.background_obj.as_deref().map(meniscus::scene::geometry::Geometry::load_obj).transpose()?;
            if let (Some(path), Some(mesh)) = (&a.scene.background_obj, &mesh) {
                match scene.add_mesh_collider(mesh) {
                    Ok(removed) => eprintln!("{}", crate::sim::collider_line(path, mesh, &scene, removed)),
                    Err(e) => eprintln!("--background-obj {}: drawn, but not a collider: {e}", path.display()),
                }
            }
            let job = Job::simulated(&scene, &a.scene, mesh, settings.clone())?;
            let mut params = settings.sim;
            if let Some(f) = &file {
                f.apply(&mut params);
            }
            (Some((scene, params)), job)
        }
        None => (None, Job::open(&a.scene, &a.load, settings, Select::default())?),
    };
    eprintln!("{}", job.summary(Some((a.width, a.height))));
    run(
        job,
        DemoOptions {
            width: a.width,
            height: a.height,
            vsync: !a.no_vsync,
            validation: a.gpu.validation,
            device: a.gpu.device.clone(),
            no_int64_atomics: a.gpu.no_int64_atomics,
            frames: a.frames,
            screenshot: a.screenshot.clone(),
            record: a.record.clone(),
            exercise_resize: a.exercise_resize,
            fps: a.fps.max(0.1),
            sim,
            async_mode: a.async_mode.clone(),
        },
    )?;
    Ok(())
}

/// Window and playback options (the particles, settings and camera come from the [`Job`]).
#[derive(Clone, Debug)]
pub struct DemoOptions {
    pub width: u32,
    pub height: u32,
    pub vsync: bool,
    pub validation: bool,
    pub device: Option<String>,
    /// Leave 64-bit buffer atomics off (`--no-int64-atomics`).
    pub no_int64_atomics: bool,
    /// Run this many frames, then exit (after writing `screenshot` if given).
    pub frames: Option<u64>,
    pub screenshot: Option<PathBuf>,
    /// Record the window into this movie from the start.
    pub record: Option<PathBuf>,
    /// Scripted resizes (see `--exercise-resize`).
    pub exercise_resize: bool,
    pub fps: f32,
    /// A live simulation to play instead of the job's particles.
    pub sim: Option<(meniscus::sim::scene::SimScene, meniscus::sim::params::Params)>,
    /// `--async`: auto, on, off.
    pub async_mode: String,
}

struct State {
    window: Arc<Window>,
    gpu: Arc<Gpu>,
    surface_loader: ash::khr::surface::Instance,
    surface: vk::SurfaceKHR,
    swap: Option<present::Swapchain>,
    renderer: Renderer,
    /// The views inside the frame (raw depth, normals, particles, …) and the overlay, recorded after its passes.
    inspector: Inspector,
    overlay: Option<Image>,
    /// Per frame slot (frames in flight): the overlay's staging buffer, the particle values, and the
    /// semaphore the swapchain's acquire signals.
    overlay_staging: Vec<Option<Buffer>>,
    values: Vec<Option<Buffer>>,
    acquired: Vec<vk::Semaphore>,
    /// The live simulation (`--sim`).
    sim: Option<meniscus::sim::Simulation>,
}

struct App {
    o: DemoOptions,
    /// The job's settings (keys change the filter, surface, SSR, preset).
    settings: Settings,
    load: LoadOptions,
    /// Background mesh (`--background-obj`).
    mesh: Option<meniscus::scene::geometry::Geometry>,
    /// The sequence frame whose particles are on the GPU (uploads happen only when it changes).
    uploaded: Option<usize>,
    /// The particles' motion over the frames played in order (the noise's amplitude); restarted by a jump.
    motion: meniscus::motion::MotionTracker,
    /// A sequence's diffuse particles, generated in time order (`[diffuse] enabled`, K).
    walk: Option<crate::diffuse::Walk>,
    /// The live simulation's diffuse stages are on (they follow `[diffuse] enabled`, K).
    sim_diffuse: bool,
    /// Diffuse particles of each kind on the GPU (foam, spray, bubbles), for the overlay.
    diffuse_counts: [usize; 3],
    src: playback::Source,
    radius: f32,
    fit: Camera,
    camera: Camera,
    env: Environment,
    /// Spheres frame by frame (a simulation's bodies: an export's scene.json, the live scene's), placed in `env`.
    tracks: Vec<meniscus::scene::splishsplash::BodyTrack>,
    state: Option<State>,
    error: Option<Error>,
    // Playback and interaction.
    frame: usize,
    playing: bool,
    speed: f32,
    looping: bool,
    last_advance: Instant,
    mode: ViewMode,
    color_by: usize,
    presets: usize,
    help: bool,
    mods: ModifiersState,
    cursor: Option<(f64, f64)>,
    dragging: Option<MouseButton>,
    keys: std::collections::HashSet<KeyCode>,
    // Stats.
    frames_drawn: u64,
    started: Instant,
    fps_window: (Instant, u32, f32),
    last_frame: Instant,
    last_times: PassTimes,
    /// Where the mesh surface was last said to be extracted (`job::say_mesh_path`).
    mesh_said: Option<String>,
    screenshot_count: u32,
    /// The movie being recorded (M, `--record`) and how many were started.
    recorder: Option<(crate::movie::Movie, PathBuf)>,
    recordings: u32,
    resized: bool,
    /// Simulation: one frame requested while paused; the last particles read back (particle view, iso, mesh).
    sim_step: bool,
    sim_particles: Option<Particles>,
}

/// Run the demo until the window closes or `frames` are done.
pub fn run(job: Job, o: DemoOptions) -> Result<()> {
    let fit = Camera::fit(&job.bounds, o.width as f32 / o.height as f32);
    let camera = job.camera_for(o.width, o.height);
    let mut first_view = job.view(o.width, o.height);
    job.place_bodies(&mut first_view, job.frames.as_ref().map_or(1, |f| f[0].number));
    let env = first_view.env;
    let tracks = job.tracks.clone();
    let radius = job.settings.radius;
    // A sequence's spray, foam and bubbles: calibrated over the sequence now (a few seconds for a long one),
    // generated as it plays.
    let walk = if job.frames.is_some() && job.settings.diffuse.enabled {
        Some(crate::diffuse::Walk::new(&job).map_err(|e| Error::Invalid(format!("{e:#}")))?)
    } else {
        None
    };
    let src = match job.frames {
        Some(frames) => {
            let mut cache = HashMap::new();
            cache.insert(0, job.first);
            playback::Source::Sequence { frames, cache, order: vec![0] }
        }
        None => playback::Source::Static(job.first),
    };
    let (s, load, mesh) = (job.settings, job.load, job.mesh);
    let event_loop = EventLoop::new().map_err(|e| {
        Error::Invalid(format!(
            "cannot open a window ({e}); the demo needs an X server: set DISPLAY, or run it under Xvfb (`Xvfb :99 & DISPLAY=:99 meniscus demo`)"
        ))
    })?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let motion_fps = o.fps;
    let mut app = App {
        camera,
        fit,
        env,
        tracks,
        src,
        radius,
        state: None,
        error: None,
        frame: 0,
        playing: true,
        speed: 1.0,
        looping: true,
        last_advance: Instant::now(),
        mode: ViewMode::Final,
        color_by: 0,
        presets: 0,
        help: false,
        mods: ModifiersState::empty(),
        cursor: None,
        dragging: None,
        keys: Default::default(),
        frames_drawn: 0,
        started: Instant::now(),
        fps_window: (Instant::now(), 0, 0.0),
        last_frame: Instant::now(),
        last_times: PassTimes::default(),
        mesh_said: None,
        screenshot_count: 0,
        recorder: None,
        recordings: 0,
        resized: false,
        sim_step: o.sim.is_some(),
        sim_particles: None,
        o,
        settings: s,
        load,
        mesh,
        uploaded: None,
        motion: meniscus::motion::MotionTracker::new(motion_fps),
        walk,
        sim_diffuse: false,
        diffuse_counts: [0; 3],
    };
    event_loop.run_app(&mut app).map_err(|e| Error::Invalid(format!("window event loop failed: {e}")))?;
    if let Some(e) = app.error.take() {
        return Err(e);
    }
    app.stop_recording().map_err(|e| Error::Invalid(format!("{e:#}")))?;
    let secs = app.started.elapsed().as_secs_f64();
    eprintln!("{} frames in {secs:.1} s ({:.2} frames/s)", app.frames_drawn, app.frames_drawn as f64 / secs.max(1e-9));
    if let Some(st) = &app.state {
        let v = st.gpu.validation();
        if v.errors() + v.warnings() > 0 {
            return Err(Error::Invalid(format!("{} Vulkan validation errors, {} warnings", v.errors(), v.warnings())));
        }
    }
    Ok(())
}

impl ApplicationHandler for App {
    fn resumed(&mut self, el: &ActiveEventLoop) {
        if self.state.is_some() {
            return;
        }
        match self.create_state(el) {
            Ok(s) => self.state = Some(s),
            Err(e) => {
                self.error = Some(e);
                el.exit();
            }
        }
    }

    fn window_event(&mut self, el: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => el.exit(),
            WindowEvent::Resized(_) => self.resized = true,
            WindowEvent::ModifiersChanged(m) => self.mods = m.state(),
            WindowEvent::KeyboardInput { event, .. } => {
                if let PhysicalKey::Code(code) = event.physical_key {
                    if event.state == ElementState::Pressed {
                        if !event.repeat {
                            self.key(code, el);
                        }
                        self.keys.insert(code);
                    } else {
                        self.keys.remove(&code);
                    }
                }
            }
            WindowEvent::MouseInput { state, button, .. } => {
                self.dragging = (state == ElementState::Pressed).then_some(button);
            }
            WindowEvent::CursorMoved { position, .. } => {
                if let (Some((x0, y0)), Some(b)) = (self.cursor, self.dragging) {
                    let (dx, dy) = ((position.x - x0) as f32, (position.y - y0) as f32);
                    if b == MouseButton::Right || (b == MouseButton::Left && self.mods.shift_key()) {
                        controller::pan(&mut self.camera, dx, dy);
                    } else if b == MouseButton::Left {
                        controller::orbit(&mut self.camera, dx, dy);
                    }
                }
                self.cursor = Some((position.x, position.y));
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let steps = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                controller::zoom(&mut self.camera, steps);
            }
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.draw(el) {
                    self.error = Some(e);
                    el.exit();
                }
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _el: &ActiveEventLoop) {
        if let Some(s) = &self.state {
            s.window.request_redraw();
        }
    }
}

impl App {
    fn create_state(&mut self, el: &ActiveEventLoop) -> Result<State> {
        let attrs = Window::default_attributes()
            .with_title("meniscus demo")
            .with_inner_size(winit::dpi::PhysicalSize::new(self.o.width, self.o.height));
        let window =
            Arc::new(el.create_window(attrs).map_err(|e| Error::Invalid(format!("cannot create a window: {e}")))?);
        let display = window.display_handle().map_err(|e| Error::Invalid(format!("no display handle: {e}")))?.as_raw();
        let wh = window.window_handle().map_err(|e| Error::Invalid(format!("no window handle: {e}")))?.as_raw();
        let exts = ash_window::enumerate_required_extensions(display).vk("enumerate surface extensions")?;
        // SAFETY: ash-window returns pointers to static NUL-terminated extension names.
        let surface_extensions = exts.iter().map(|&p| unsafe { std::ffi::CStr::from_ptr(p) }).collect();
        let gpu = Gpu::new(&GpuOptions {
            validation: self.o.validation,
            device_filter: self.o.device.clone(),
            surface_extensions,
            no_int64_atomics: self.o.no_int64_atomics,
        })?;
        // SAFETY: the handles come from a live window that outlives the surface (State drops the surface first).
        let surface = unsafe { ash_window::create_surface(&gpu.entry, &gpu.instance, display, wh, None) }
            .vk("vkCreateSurfaceKHR")?;
        let surface_loader = ash::khr::surface::Instance::new(&gpu.entry, &gpu.instance);
        let ok = unsafe { surface_loader.get_physical_device_surface_support(gpu.physical, gpu.queue_family, surface) }
            .vk("vkGetPhysicalDeviceSurfaceSupportKHR")?;
        if !ok {
            return Err(Error::NoDevice(format!("{} cannot present to this window", gpu.info.name)));
        }
        let sim = match &self.o.sim {
            Some((scene, params)) => {
                let sim = meniscus::sim::Simulation::new(&gpu, scene.clone(), params.clone())?;
                eprintln!(
                    "sim {}: {} particles, {} steps of {:.2} ms per frame, {} iterations",
                    scene.name,
                    sim.count(),
                    sim.constants.substeps,
                    sim.constants.dt * 1e3,
                    sim.params.iterations
                );
                Some(sim)
            }
            None => None,
        };
        let mut renderer = Renderer::new(&gpu)?;
        *renderer.parts_mut().async_compute = match self.o.async_mode.as_str() {
            "on" => true,
            "off" => false,
            _ => gpu.queues.kind != meniscus::device::AsyncQueue::SameQueue,
        };
        if let Some(m) = &self.mesh {
            renderer.set_background(Backdrop::Mesh(m))?;
        }
        eprintln!("demo on {} ({}); keys:\n{HELP}", gpu.info.name, gpu.info.driver);
        let n = renderer.slots().count();
        let inspector = Inspector::new(&gpu)?;
        let acquired = (0..n).map(|_| present::semaphore(&gpu)).collect::<Result<Vec<_>>>()?;
        let mut st = State {
            window,
            gpu,
            surface_loader,
            surface,
            swap: None,
            inspector,
            renderer,
            overlay: None,
            overlay_staging: (0..n).map(|_| None).collect(),
            values: (0..n).map(|_| None).collect(),
            acquired,
            sim,
        };
        self.recreate_swapchain(&mut st)?;
        Ok(st)
    }

    fn recreate_swapchain(&self, st: &mut State) -> Result<()> {
        let size = st.window.inner_size();
        let surface = present::Surface { loader: &st.surface_loader, raw: st.surface, size: (size.width, size.height) };
        st.swap = present::recreate(&st.gpu, surface, self.o.vsync, st.swap.take())?;
        if let Some(sw) = &st.swap {
            eprintln!("swapchain {}×{}", sw.extent.width, sw.extent.height);
        }
        Ok(())
    }

    /// The pushing sphere under the mouse: on the plane through the container's centre facing the camera,
    /// an eighth of the container's size.
    fn pusher(&self, sim: &meniscus::sim::Simulation, extent: vk::Extent2D) -> Option<(Vec3, f32)> {
        let (x, y) = self.cursor?;
        let (lo, hi) = sim.scene.container;
        let centre = 0.5 * (lo + hi);
        let c = &self.camera;
        let f = c.focal_px(extent.height);
        let dir_view = Vec3::new(
            (x as f32 + 0.5 - 0.5 * extent.width as f32) / f,
            -(y as f32 + 0.5 - 0.5 * extent.height as f32) / f,
            -1.0,
        );
        let dir = c.view().inverse().transform_vector3(dir_view).normalize();
        let forward = (c.target - c.eye).normalize();
        let denom = dir.dot(forward);
        if denom.abs() < 1e-4 {
            return None;
        }
        let t = (centre - c.eye).dot(forward) / denom;
        let p = c.eye + dir * t;
        Some((p.clamp(lo, hi), 0.125 * (hi - lo).max_element()))
    }

    /// The fly keys held now, as (forward, right, up) in {-1, 0, 1}.
    fn fly_keys(&self) -> (f32, f32, f32) {
        let axis = |plus: KeyCode, minus: KeyCode| {
            self.keys.contains(&plus) as i32 as f32 - self.keys.contains(&minus) as i32 as f32
        };
        (axis(KeyCode::KeyW, KeyCode::KeyS), axis(KeyCode::KeyD, KeyCode::KeyA), axis(KeyCode::KeyE, KeyCode::KeyQ))
    }

    /// Per-particle values in [0, 1] for the particle view (speed, density or height), and the legend range.
    fn values(&self, p: &Particles) -> (Vec<f32>, String, f32, f32) {
        let (name, raw): (&str, Vec<f32>) = match self.color_by {
            0 => (
                "speed",
                p.velocities
                    .as_ref()
                    .map(|v| v.iter().map(|v| Vec3::from(*v).length()).collect())
                    .unwrap_or_else(|| vec![0.0; p.len()]),
            ),
            1 => ("density", p.densities.clone().unwrap_or_else(|| vec![0.0; p.len()])),
            _ => ("height", p.positions.iter().map(|q| q[1]).collect()),
        };
        let mut sorted: Vec<f32> = raw.iter().copied().filter(|x| x.is_finite()).collect();
        sorted.sort_by(f32::total_cmp);
        let (lo, hi) = if sorted.is_empty() {
            (0.0, 1.0)
        } else {
            (sorted[sorted.len() / 50], sorted[sorted.len() - 1 - sorted.len() / 50])
        };
        let span = (hi - lo).max(1e-9);
        (raw.iter().map(|x| (x - lo) / span).collect(), name.to_string(), lo, hi)
    }
}

impl Drop for State {
    fn drop(&mut self) {
        if let Some(s) = self.swap.take() {
            present::destroy(&self.gpu, s);
        }
        unsafe {
            let _ = self.gpu.device.device_wait_idle();
            for &sem in &self.acquired {
                self.gpu.device.destroy_semaphore(sem, None);
            }
        }
        unsafe { self.surface_loader.destroy_surface(self.surface, None) };
    }
}
