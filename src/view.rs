//! What a frame is seen from: the camera, the output size and the static scene around the fluid (a ground plane,
//! a few boxes or a container's walls), and how every front end frames particles (`View::around`).

use glam::Vec3;

use crate::scene::camera::Camera;
use crate::scene::Bounds;
use crate::settings::Settings;

/// The static scene around the fluid: a ground plane and a few boxes.
#[derive(Clone, Debug, PartialEq)]
pub struct Environment {
    /// Height (y) of the ground plane.
    pub ground_y: f32,
    /// Side of a ground checker tile.
    pub tile: f32,
    /// Distance at which the fog hides the scene.
    pub fog: f32,
    /// Whether the ground plane is drawn.
    pub ground: bool,
    /// Axis-aligned boxes beside the fluid, as (min, max) corners.
    pub boxes: Vec<(Vec3, Vec3)>,
    /// Spheres (centre, radius): a simulation's moving bodies, placed per frame.
    pub spheres: Vec<(Vec3, f32)>,
    /// A sky cube map is loaded in the renderer (see `Renderer::set_skybox`).
    pub sky_cube: bool,
}

impl Environment {
    /// Ground just under the fluid's lower percentile; with `boxes`, two pillars behind the fluid and a
    /// low block beside it, sized from the fluid's extent (so they show in reflections and refraction).
    pub fn around(b: &Bounds, radius: f32, s: &Settings) -> Environment {
        let ext = (b.hi - b.lo).max(Vec3::splat(radius * 4.0));
        let size = ext.max_element();
        let ground_y = b.lo.y - radius;
        let mut boxes = vec![];
        if s.background.boxes {
            let w = size * 0.06;
            let h = size * 0.3;
            let z0 = b.lo.z - size * 0.15;
            for fx in [0.2f32, 0.75] {
                let x = b.lo.x + fx * ext.x;
                boxes.push((Vec3::new(x, ground_y, z0 - w), Vec3::new(x + w, ground_y + h, z0)));
            }
            let x = b.hi.x + w * 1.5;
            boxes.push((
                Vec3::new(x, ground_y, b.lo.z + ext.z * 0.3),
                Vec3::new(x + 2.0 * w, ground_y + 0.5 * h, b.lo.z + ext.z * 0.3 + 2.0 * w),
            ));
        }
        let tile = (size / 8.0).max(radius * 4.0);
        Environment {
            ground_y,
            tile,
            fog: size * 12.0,
            ground: s.background.ground,
            boxes,
            spheres: vec![],
            sky_cube: false,
        }
    }
}

/// Everything that defines one frame's view.
#[derive(Clone, Debug)]
pub struct View {
    /// The camera.
    pub camera: Camera,
    /// Output width in pixels.
    pub width: u32,
    /// Output height in pixels.
    pub height: u32,
    /// The static scene around the fluid.
    pub env: Environment,
}

impl View {
    /// The view of a `width`×`height` output of particles whose 1st–99th percentile box is `bounds`: `camera`,
    /// or one fitted to the box for the output's aspect; the default background scene around them. What every
    /// front end (the CLI's job, the Python package) frames particles with.
    pub fn around(bounds: &Bounds, camera: Option<Camera>, width: u32, height: u32, s: &Settings) -> View {
        let camera = camera.unwrap_or_else(|| Camera::fit(bounds, width as f32 / height.max(1) as f32));
        View { camera, width, height, env: Environment::around(bounds, s.radius, s) }
    }
}

/// What the demo shows: the shaded frame or one of the frame's buffers (the `view` pass draws them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewMode {
    /// The shaded fluid.
    Final,
    /// Raw splatted depth.
    Depth,
    /// Smoothed depth.
    Smoothed,
    /// Thickness (heat map).
    Thickness,
    /// View-space normals.
    Normals,
    /// Screen-space reflection hits.
    Ssr,
    /// The particles as lit spheres coloured by an attribute.
    Particles,
}

impl ViewMode {
    /// Every mode, in key order.
    pub const ALL: [ViewMode; 7] = [
        ViewMode::Final,
        ViewMode::Depth,
        ViewMode::Smoothed,
        ViewMode::Thickness,
        ViewMode::Normals,
        ViewMode::Ssr,
        ViewMode::Particles,
    ];
    /// The mode's name in the overlay.
    pub fn name(self) -> &'static str {
        match self {
            ViewMode::Final => "final",
            ViewMode::Depth => "raw depth",
            ViewMode::Smoothed => "smoothed depth",
            ViewMode::Thickness => "thickness",
            ViewMode::Normals => "normals",
            ViewMode::Ssr => "ssr hits",
            ViewMode::Particles => "particles",
        }
    }
}
