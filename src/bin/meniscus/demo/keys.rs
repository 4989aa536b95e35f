//! The demo's keys: what each key does to the view, the settings, the playback, the simulation and the
//! recording (the list the window's help shows is `super::HELP`).

use super::*;

impl App {
    pub(super) fn key(&mut self, code: KeyCode, el: &ActiveEventLoop) {
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
                let size =
                    self.state.as_ref().and_then(|st| st.renderer.state().targets().map(|t| (t.width, t.height)));
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
}
