//! Drawing one demo frame: the playback's or the simulation's next particles, the renderer's frame, the pass
//! view chosen, the overlay's text, the blit to the window, the recording and the screenshots.

use super::*;

impl App {
    pub(super) fn draw(&mut self, el: &ActiveEventLoop) -> Result<()> {
        let Some(mut st) = self.state.take() else { return Ok(()) };
        let r = self.draw_inner(&mut st, el);
        self.state = Some(st);
        r
    }

    pub(super) fn draw_inner(&mut self, st: &mut State, el: &ActiveEventLoop) -> Result<()> {
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
        let produce = self.advance_sim(st, now, due, extent)?;
        if self.playing && n > 1 && due {
            self.last_advance = now;
            match playback::next_frame(self.frame, n, self.looping) {
                Some(f) => self.frame = f,
                None => self.playing = false,
            }
        }
        let view = View { camera: self.camera, width: extent.width, height: extent.height, env: self.env.clone() };
        // Upload only when the frame changed (or a preset changed the `[isolated]` settings): re-uploading also
        // dropped the iso grid, which was then rebuilt every frame of a static scene.
        self.upload_frame(st)?;
        // Frames in flight: the slot this frame takes is free once the frame N back is done (the only host wait).
        let k = st.renderer.slots().next();
        st.renderer.slots().wait(k)?;
        let legend = self.particle_values(st, k)?;
        // Overlay text (the GPU times of an earlier frame: a frame's are read when its slot comes round again).
        let (ow, oh) = self.stage_overlay(st, k, n, legend.as_ref(), extent)?;
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
        *st.renderer.parts_mut().keep_raw_depth = true;
        st.renderer.submit(FrameRequest { hooks, binary, ..FrameRequest::new(&view, &self.settings) })?;
        crate::job::say_mesh_path(&st.renderer, &self.settings, &mut self.mesh_said);
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
        self.after_present(st, now, el)
    }

    /// The live simulation's next frame when one is due (spray, foam and bubbles switched with `[diffuse]
    /// enabled`, their counts read twice a second); returns whether the frame's particles come from the solver's
    /// buffer (recorded into the frame) rather than an upload.
    fn advance_sim(&mut self, st: &mut State, now: Instant, due: bool, extent: vk::Extent2D) -> Result<bool> {
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
                // A moving body is drawn where the frames so far left it (a wait for the device: one frame late,
                // the last of the live scene's spheres).
                if sim.scene.body.is_some() && sim.frames > 0 {
                    st.renderer.slots().wait_all()?;
                    if let (Some(b), Some(last)) = (sim.body_state()?, self.env.spheres.last_mut()) {
                        last.0 = b.centre;
                    }
                }
                // The mesh surface meshes GPU-written particles on the GPU (live); only its CPU extraction needs
                // them on the host.
                let cpu_mesh = self.settings.surface == Surface::Mesh
                    && self.settings.mesh.extraction == meniscus::surface::mesh::params::Extraction::Cpu;
                if !cpu_mesh && self.mode != ViewMode::Particles {
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
            if let playback::Source::Sequence { frames, .. } = &self.src {
                let number = frames[self.frame].number;
                self.env.spheres = meniscus::scene::splishsplash::BodyTrack::spheres_at(&self.tracks, number);
            }
            self.uploaded = Some(self.frame);
        }
        Ok(produce)
    }

    /// Upload the playback's frame when it changed (the motion continued in time order, the diffuse particles
    /// walked along).
    fn upload_frame(&mut self, st: &mut State) -> Result<()> {
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
        Ok(())
    }

    /// In the particle view: the particles' values in slot `k`'s buffer, and the legend (name, low, high).
    fn particle_values(&mut self, st: &mut State, k: usize) -> Result<Option<(String, f32, f32)>> {
        if self.mode != ViewMode::Particles {
            return Ok(None);
        }
        {
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
            Ok(Some((name, lo, hi)))
        }
    }

    /// The overlay's text rasterised into slot `k`'s staging buffer (its image remade when its size changed);
    /// returns the overlay's size.
    fn stage_overlay(
        &mut self,
        st: &mut State,
        k: usize,
        n: usize,
        legend: Option<&(String, f32, f32)>,
        extent: vk::Extent2D,
    ) -> Result<(u32, u32)> {
        let text = self.overlay_text(st, n, legend);
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
        Ok((ow, oh))
    }

    /// After the frame is presented: the counts, the recording, the frame rate, the resize exercise and the
    /// screenshot and exit after `--frames`.
    fn after_present(&mut self, st: &mut State, now: Instant, el: &ActiveEventLoop) -> Result<()> {
        self.frames_drawn += 1;
        self.fps_window.1 += 1;
        if self.recorder.is_none() && self.recordings == 0 && self.o.record.is_some() {
            let p = self.o.record.clone();
            let size = st.renderer.state().targets().map_or((self.o.width, self.o.height), |t| (t.width, t.height));
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

    pub(super) fn overlay_text(&self, st: &State, n: usize, legend: Option<&(String, f32, f32)>) -> Vec<String> {
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
                if st.renderer.state().async_compute() { "on" } else { "off" }
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
    pub(super) fn start_recording(&mut self, path: Option<PathBuf>, size: (u32, u32)) -> anyhow::Result<()> {
        self.recordings += 1;
        let path = path.unwrap_or_else(|| PathBuf::from(format!("meniscus-recording-{:04}.mp4", self.recordings)));
        let kind = crate::args::out_kind("--record", &path, &crate::movie::MOVIE_KINDS)?;
        let movie = crate::movie::Movie::start(&path, kind, size.0, size.1, self.o.fps, &Default::default())?;
        eprintln!("recording {} (M stops)", path.display());
        self.recorder = Some((movie, path));
        Ok(())
    }

    /// Finish the movie being recorded, if any.
    pub(super) fn stop_recording(&mut self) -> anyhow::Result<()> {
        if let Some((movie, path)) = self.recorder.take() {
            let n = movie.finish()?;
            eprintln!("recorded {n} frames → {}", path.display());
        }
        Ok(())
    }

    pub(super) fn save_screenshot(&mut self, p: &std::path::Path) -> Result<()> {
        let st = self.state.as_ref().ok_or_else(|| Error::Invalid("no window yet".into()))?;
        self.save_screenshot_of(st, p)
    }

    pub(super) fn save_screenshot_of(&self, st: &State, p: &std::path::Path) -> Result<()> {
        let img = st.renderer.state().read_final()?;
        meniscus::output::write_png(p, &img)
    }
}
