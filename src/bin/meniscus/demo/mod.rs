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
    let env = job.view(o.width, o.height).env;
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
        renderer.async_compute = match self.o.async_mode.as_str() {
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

    fn key(&mut self, code: KeyCode, el: &ActiveEventLoop) {
        let n = self.src.len();
        match code {
            KeyCode::Escape => el.exit(),
            KeyCode::Space => self.playing = !self.playing,
            KeyCode::ArrowRight if self.o.sim.is_some() => {
                self.playing = false;
                self.sim_step = true;
            }
            KeyCode::Backspace => {
                if let Some(sim) = self.state.as_mut().and_then(|s| s.sim.as_mut()) {
                    sim.reset();
                    self.sim_step = true;
                }
            }
            KeyCode::ArrowRight => {
                self.playing = false;
                self.frame = (self.frame + 1) % n;
            }
            KeyCode::ArrowLeft => {
                self.playing = false;
                self.frame = (self.frame + n - 1) % n;
            }
            KeyCode::ArrowUp => self.speed = (self.speed * 2.0).min(64.0),
            KeyCode::ArrowDown => self.speed = (self.speed * 0.5).max(1.0 / 64.0),
            KeyCode::KeyL => self.looping = !self.looping,
            KeyCode::KeyR => self.camera = self.fit,
            KeyCode::KeyC => println!("--camera {}", self.camera.to_arg()),
            KeyCode::KeyH => self.help = !self.help,
            KeyCode::KeyB => self.color_by = (self.color_by + 1) % 3,
            KeyCode::KeyF => {
                const ORDER: [Filter; 6] = [
                    Filter::NarrowRange,
                    Filter::Bilateral,
                    Filter::Bilateral2d,
                    Filter::CurvatureFlow,
                    Filter::Gaussian,
                    Filter::None,
                ];
                let k = ORDER.iter().position(|f| *f == self.settings.filter.method).unwrap_or(0);
                self.settings.filter.method = ORDER[(k + 1) % ORDER.len()];
            }
            KeyCode::KeyG => {
                let s = &mut self.settings.fluid_scale;
                *s = if *s > 0.75 {
                    0.5
                } else if *s > 0.375 {
                    0.25
                } else {
                    1.0
                };
            }
            KeyCode::KeyX => self.settings.ssr.enabled = !self.settings.ssr.enabled,
            KeyCode::KeyN => self.settings.noise.enabled = !self.settings.noise.enabled,
            KeyCode::KeyK => {
                self.settings.diffuse.enabled = !self.settings.diffuse.enabled;
                // Generation resumes where it stopped (a sequence walks on from its last frame).
                self.uploaded = None;
                self.sim_step |= self.o.sim.is_some() && !self.playing;
            }
            KeyCode::KeyI => {
                let next = match self.settings.surface {
                    Surface::Spheres => Surface::Iso,
                    Surface::Iso => Surface::Mesh,
                    Surface::Mesh => Surface::Spheres,
                };
                self.settings.set_surface(next);
            }
            KeyCode::KeyO => {
                // Every preset, in the library's order (`smooth` last).
                let names = meniscus::settings::PRESETS;
                self.presets = (self.presets + 1) % names.len();
                match Settings::preset(names[self.presets]) {
                    Ok(mut s) => {
                        s.radius = self.radius;
                        self.settings = s;
                        self.uploaded = None;
                        eprintln!("preset {}", names[self.presets]);
                    }
                    Err(e) => eprintln!("{e}"),
                }
            }
            KeyCode::KeyV => {
                self.o.vsync = !self.o.vsync;
                self.resized = true;
            }
            KeyCode::KeyM => {
                let size = self.state.as_ref().and_then(|st| st.renderer.targets.as_ref().map(|t| (t.width, t.height)));
                let r = if self.recorder.is_some() {
                    self.stop_recording()
                } else {
                    self.start_recording(None, size.unwrap_or((self.o.width, self.o.height)))
                };
                if let Err(e) = r {
                    eprintln!("recording failed: {e:#}");
                }
            }
            KeyCode::KeyP => {
                self.screenshot_count += 1;
                let p = PathBuf::from(format!("meniscus-screenshot-{:04}.png", self.screenshot_count));
                if let Err(e) = self.save_screenshot(&p) {
                    eprintln!("screenshot failed: {e}");
                } else {
                    eprintln!("wrote {}", p.display());
                }
            }
            c => {
                let digits = [
                    KeyCode::Digit1,
                    KeyCode::Digit2,
                    KeyCode::Digit3,
                    KeyCode::Digit4,
                    KeyCode::Digit5,
                    KeyCode::Digit6,
                    KeyCode::Digit7,
                ];
                if let Some(k) = digits.iter().position(|d| *d == c) {
                    self.mode = ViewMode::ALL[k];
                }
            }
        }
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

    fn draw(&mut self, el: &ActiveEventLoop) -> Result<()> {
        let Some(mut st) = self.state.take() else { return Ok(()) };
        let r = self.draw_inner(&mut st, el);
        self.state = Some(st);
        r
    }

    fn draw_inner(&mut self, st: &mut State, el: &ActiveEventLoop) -> Result<()> {
        if self.resized {
            self.resized = false;
            self.recreate_swapchain(st)?;
        }
        let Some(extent) = st.swap.as_ref().map(|s| s.extent) else {
            std::thread::sleep(Duration::from_millis(30)); // minimised
            return Ok(());
        };
        // Playback.
        let now = Instant::now();
        let dt = now.duration_since(self.last_frame).as_secs_f32().min(0.1);
        self.last_frame = now;
        let keys = self.fly_keys();
        controller::fly(&mut self.camera, keys, dt);
        let n = self.src.len();
        let due = now.duration_since(self.last_advance).as_secs_f32() >= 1.0 / (self.o.fps * self.speed);
        // The live simulation: one simulated frame per due frame while playing (or one on request).
        let mut produce = false;
        if let Some(sim) = st.sim.as_mut() {
            sim.pusher = if self.mods.control_key() { self.pusher(sim, extent) } else { None };
            if (self.playing && due) || self.sim_step {
                self.last_advance = now;
                self.sim_step = false;
                // The spheres and iso surfaces draw straight from the solver's buffer (the iso surface's grid is
                // built on the GPU); the mesh surface and the particle view need the particles on the host (a
                // readback per frame).
                // Spray, foam and bubbles: stages of the simulation on the GPU, switched with [diffuse] enabled.
                let diffuse = self.settings.diffuse.enabled;
                if diffuse != self.sim_diffuse {
                    st.renderer.slots().wait_all()?;
                    sim.set_diffuse(diffuse.then_some(&self.settings.diffuse))?;
                    self.sim_diffuse = diffuse;
                    self.diffuse_counts = [0; 3];
                }
                // Their counts for the overlay: read back twice a second (a wait for the device).
                if diffuse && sim.frames % 12 == 11 {
                    st.renderer.slots().wait_all()?;
                    let mut c = [0; 3];
                    for p in sim.read_diffuse()? {
                        c[p.kind as usize] += 1;
                    }
                    self.diffuse_counts = c;
                }
                if self.settings.surface != Surface::Mesh && self.mode != ViewMode::Particles {
                    st.renderer.upload(Upload::Gpu {
                        count: sim.count(),
                        bounds: sim.scene.container,
                        diffuse_slots: sim.diffuse_slots(),
                    })?;
                    produce = true;
                    self.sim_particles = None;
                } else {
                    sim.step_frame()?;
                    let p = sim.read()?;
                    st.renderer.upload(Upload::Scene {
                        particles: &p,
                        settings: &self.settings,
                        motion: Some(&sim.read_motion()?),
                        ahead: None,
                    })?;
                    if diffuse {
                        st.renderer
                            .upload(Upload::Diffuse { particles: &sim.read_diffuse()?, settings: &self.settings })?;
                    } else if st.renderer.state().particles().diffuse_count() > 0 {
                        st.renderer.upload(Upload::Diffuse { particles: &[], settings: &self.settings })?;
                    }
                    self.sim_particles = Some(p);
                }
            }
            self.uploaded = Some(self.frame);
        }
        if self.playing && n > 1 && due {
            self.last_advance = now;
            match playback::next_frame(self.frame, n, self.looping) {
                Some(f) => self.frame = f,
                None => self.playing = false,
            }
        }
        let view = View { camera: self.camera, width: extent.width, height: extent.height, env: self.env.clone() };
        // Upload only when the frame changed (or a preset changed the spray settings): re-uploading also
        // dropped the iso grid, which was then rebuilt every frame of a static scene.
        if self.uploaded != Some(self.frame) {
            // The next frame in time order continues the motion; any other jump starts it again.
            if self.uploaded.is_none_or(|u| u + 1 != self.frame) {
                self.motion = meniscus::motion::MotionTracker::new(self.o.fps);
            }
            let p = self.src.get(self.frame, &self.load)?;
            let motion = self.motion.next(p);
            st.renderer.upload(Upload::Scene {
                particles: p,
                settings: &self.settings,
                motion: Some(&motion),
                ahead: None,
            })?;
            if let (true, Some(walk), playback::Source::Sequence { frames, .. }) =
                (self.settings.diffuse.enabled, self.walk.as_mut(), &self.src)
            {
                let number = frames[self.frame].number;
                let p = self.src.get(self.frame, &self.load)?;
                let ps = walk.advance(number, Some(p)).map_err(|e| Error::Invalid(format!("{e:#}")))?;
                st.renderer.upload(Upload::Diffuse { particles: ps, settings: &self.settings })?;
                self.diffuse_counts = walk.counts();
            } else if !self.settings.diffuse.enabled && st.renderer.state().particles().diffuse_count() > 0 {
                st.renderer.upload(Upload::Diffuse { particles: &[], settings: &self.settings })?;
                self.diffuse_counts = [0; 3];
            }
            self.uploaded = Some(self.frame);
        }
        // Frames in flight: the slot this frame takes is free once the frame N back is done (the only host wait).
        let k = st.renderer.slots().next();
        st.renderer.slots().wait(k)?;
        let legend = if self.mode == ViewMode::Particles {
            let p = match &self.sim_particles {
                Some(p) => p.clone(),
                None if st.sim.is_some() => {
                    let p = st.sim.as_ref().expect("checked").read()?;
                    st.renderer.upload(Upload::scene(&p, &self.settings))?;
                    self.sim_particles = Some(p.clone());
                    p
                }
                None => self.src.get(self.frame, &self.load)?.clone(),
            };
            let (vals, name, lo, hi) = self.values(&p);
            let bytes: &[u8] = bytemuck::cast_slice(&vals);
            let reuse = st.values[k].as_ref().is_some_and(|b| b.size >= bytes.len() as u64);
            if !reuse {
                st.values[k] = Some(Buffer::new(
                    &st.gpu,
                    "values",
                    bytes.len().max(16) as u64,
                    vk::BufferUsageFlags::STORAGE_BUFFER,
                    MemoryLocation::CpuToGpu,
                )?);
            }
            st.values[k].as_mut().expect("set").write(0, bytes)?;
            Some((name, lo, hi))
        } else {
            None
        };
        // Overlay text (the GPU times of an earlier frame: a frame's are read when its slot comes round again).
        let text = self.overlay_text(st, n, legend.as_ref());
        let ov = overlay::rasterize(&text, legend.is_some(), if extent.width >= 1000 { 2 } else { 1 });
        let (ow, oh) = (ov.width().min(extent.width), ov.height().min(extent.height));
        let need_new = st.overlay.as_ref().is_none_or(|o| o.extent.width != ow || o.extent.height != oh);
        if need_new {
            st.renderer.slots().wait_all()?; // frames in flight still read the old overlay image
            st.overlay = Some(Image::new(
                &st.gpu,
                "overlay",
                vk::Extent2D { width: ow, height: oh },
                vk::Format::R8G8B8A8_UNORM,
                vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_DST,
                None,
            )?);
        }
        let cropped = image::imageops::crop_imm(&ov, 0, 0, ow, oh).to_image();
        let bytes = cropped.as_raw();
        if st.overlay_staging[k].as_ref().is_none_or(|b| (b.size as usize) < bytes.len()) {
            st.overlay_staging[k] = Some(Buffer::new(
                &st.gpu,
                "overlay staging",
                bytes.len().max(16) as u64,
                vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::CpuToGpu,
            )?);
        }
        st.overlay_staging[k].as_mut().expect("set").write(0, bytes)?;
        // Acquire the swapchain image (signals the slot's semaphore; no fence, no host wait).
        let swap = st.swap.as_ref().expect("checked above");
        let Some((index, suboptimal)) = present::acquire(swap, st.acquired[k])? else {
            self.resized = true;
            return Ok(());
        };
        self.resized |= suboptimal;
        let overlay_img = st.overlay.as_ref().expect("set");
        let staging = st.overlay_staging[k].as_ref().expect("set");
        let upload_overlay = |ctx: &mut FrameCtx| {
            meniscus::device::record_upload(ctx, staging, overlay_img, vk::Extent2D { width: ow, height: oh })
        };
        let values = if self.mode == ViewMode::Particles { st.values[k].as_ref() } else { None };
        let (inspector, overlay, mode, settings) = (&st.inspector, st.overlay.as_ref(), self.mode, &self.settings);
        // The chosen view and the overlay over the final image, then its blit into the swapchain image.
        let after = |ctx: &mut FrameCtx, f: &FrameImages| {
            inspector.record(ctx, f, mode, values, overlay, settings);
            present::record_blit(ctx, swap, index, f.images.final_color)
        };
        // The simulation's frame, recorded into this frame's command buffer; it writes the particle buffer the
        // passes read.
        let sim_cell = std::cell::RefCell::new(st.sim.as_mut());
        let sim_err = std::cell::RefCell::new(None);
        let step = |ctx: &mut FrameCtx, out: &Buffer| {
            if let Some(sim) = sim_cell.borrow_mut().as_mut() {
                if let Err(e) = sim.record_frame(ctx, Some(out)) {
                    *sim_err.borrow_mut() = Some(e);
                }
            }
        };
        let hooks = Hooks {
            before: Some(&upload_overlay),
            after: Some(&after),
            produce: if produce { Some(&step) } else { None },
        };
        let binary = Binary {
            wait: Some((st.acquired[k], vk::PipelineStageFlags2::ALL_COMMANDS)),
            signal: Some(present::rendered(swap, index)),
        };
        // The raw depth view and the particle view read the splatted depth after smoothing.
        st.renderer.keep_raw_depth = true;
        st.renderer.submit(FrameRequest { hooks, binary, ..FrameRequest::new(&view, &self.settings) })?;
        let late = st.renderer.state().late_times().cloned();
        if let Some(e) = sim_err.into_inner() {
            return Err(e);
        }
        if let Some(t) = late {
            self.last_times = t;
        }
        if present::queue_present(&st.gpu, swap, index)? {
            self.resized = true;
        }
        self.frames_drawn += 1;
        self.fps_window.1 += 1;
        if self.recorder.is_none() && self.recordings == 0 && self.o.record.is_some() {
            let p = self.o.record.clone();
            let size = st.renderer.targets.as_ref().map_or((self.o.width, self.o.height), |t| (t.width, t.height));
            self.start_recording(p, size).map_err(|e| Error::Invalid(format!("{e:#}")))?;
        }
        if let Some((movie, _)) = self.recorder.as_mut() {
            // The movie keeps the window's first size: a resized window's frames are scaled to it.
            let img = st.renderer.state().read_final()?;
            let (w, h) = movie.size();
            let img = if img.dimensions() == (w, h) {
                img
            } else {
                image::imageops::resize(&img, w, h, image::imageops::FilterType::Triangle)
            };
            movie.push(&img).map_err(|e| Error::Invalid(format!("{e:#}")))?;
        }
        let el_s = now.duration_since(self.fps_window.0).as_secs_f32();
        if el_s >= 0.5 {
            self.fps_window = (now, 0, self.fps_window.1 as f32 / el_s);
        }
        if let (Some(limit), true) = (self.o.frames, self.o.exercise_resize) {
            let size = if self.frames_drawn == limit / 3 {
                Some(((self.o.width * 3 / 4).max(1), (self.o.height * 3 / 4).max(1)))
            } else if self.frames_drawn == 2 * limit / 3 {
                Some((self.o.width, self.o.height))
            } else {
                None
            };
            if let Some((w, h)) = size {
                let _ = st.window.request_inner_size(winit::dpi::PhysicalSize::new(w, h));
            }
        }
        if let Some(limit) = self.o.frames {
            if self.frames_drawn >= limit {
                if let Some(p) = self.o.screenshot.clone() {
                    self.save_screenshot_of(st, &p)?;
                    eprintln!("wrote {}", p.display());
                }
                el.exit();
            }
        }
        Ok(())
    }

    fn overlay_text(&self, st: &State, n: usize, legend: Option<&(String, f32, f32)>) -> Vec<String> {
        let s = &self.settings;
        let mut t = vec![
            format!("meniscus demo  {}", st.gpu.info.name),
            format!(
                "frame {}/{}  {}  speed {}x  loop {}   {:.1} FPS   {} particles",
                self.frame + 1,
                n,
                if self.playing { "playing" } else { "paused" },
                self.speed,
                if self.looping { "on" } else { "off" },
                self.fps_window.2,
                st.renderer.state().particles().count()
            ),
            format!(
                "view {}  surface {}  filter {}  fluid scale {}  ssr {}  noise {}  vsync {}  async {}",
                self.mode.name(),
                s.surface.name(),
                s.filter.method.name(),
                s.fluid_scale,
                if s.ssr.enabled { "on" } else { "off" },
                if s.noise.enabled { "on" } else { "off" },
                if self.o.vsync { "on" } else { "off" },
                if st.renderer.async_compute { "on" } else { "off" }
            ),
        ];
        if self.settings.diffuse.enabled && (self.walk.is_some() || st.sim.is_some()) {
            let [foam, spray, bubbles] = self.diffuse_counts;
            t.push(format!(
                "diffuse {} particles: foam {foam}  spray {spray}  bubbles {bubbles}   K: off",
                foam + spray + bubbles
            ));
        }
        if let Some(sim) = &st.sim {
            t.push(format!(
                "sim {}  t = {:.2} s  {} steps x {} iterations per frame  {}",
                sim.scene.name,
                sim.time,
                sim.constants.substeps,
                sim.params.iterations,
                if sim.pusher.is_some() { "pushing" } else { "Ctrl+mouse: push" }
            ));
        }
        // Per-pass GPU ms of the last frame, four to a line.
        let mut entries: Vec<String> = self.last_times.0.iter().map(|(n, ms)| format!("{n} {ms:.1}")).collect();
        entries.push(format!("total {:.1}", self.last_times.total()));
        for (k, chunk) in entries.chunks(4).enumerate() {
            t.push(format!("{}{}", if k == 0 { "GPU ms: " } else { "        " }, chunk.join("  ")));
        }
        if let Some((name, lo, hi)) = legend {
            t.push(format!("colour by {name}: {lo:.3} (blue) .. {hi:.3} (red)"));
        }
        if self.help {
            t.extend(HELP.lines().map(|l| l.to_string()));
        } else {
            t.push("H: help".into());
        }
        t
    }

    /// Start recording the window into `path` (default: the next free meniscus-recording-NNNN.mp4).
    fn start_recording(&mut self, path: Option<PathBuf>, size: (u32, u32)) -> anyhow::Result<()> {
        self.recordings += 1;
        let path = path.unwrap_or_else(|| PathBuf::from(format!("meniscus-recording-{:04}.mp4", self.recordings)));
        let kind = crate::args::out_kind("--record", &path, &crate::movie::MOVIE_KINDS)?;
        let movie = crate::movie::Movie::start(&path, kind, size.0, size.1, self.o.fps, &Default::default())?;
        eprintln!("recording {} (M stops)", path.display());
        self.recorder = Some((movie, path));
        Ok(())
    }

    /// Finish the movie being recorded, if any.
    fn stop_recording(&mut self) -> anyhow::Result<()> {
        if let Some((movie, path)) = self.recorder.take() {
            let n = movie.finish()?;
            eprintln!("recorded {n} frames → {}", path.display());
        }
        Ok(())
    }

    fn save_screenshot(&mut self, p: &std::path::Path) -> Result<()> {
        let st = self.state.as_ref().ok_or_else(|| Error::Invalid("no window yet".into()))?;
        self.save_screenshot_of(st, p)
    }

    fn save_screenshot_of(&self, st: &State, p: &std::path::Path) -> Result<()> {
        let img = st.renderer.state().read_final()?;
        meniscus::output::write_png(p, &img)
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
