//! The frame: its uniform block, its view, and `record_frame` — the table of contents of Meniscus (the images
//! are in `targets`, the passes in `passes`, the surface techniques in `surface`).
//! Each pass derives its own barriers from the resources' last accesses; nothing here synchronises by hand.

use glam::{Mat4, Vec3};

use crate::background::Background;
use crate::effect::{EffectFrame, Effects, FrameParticles};
use crate::error::Result;
use crate::gpu::Buffer;
use crate::passes::composite::CompositeInputs;
use crate::settings::Settings;
use crate::surface::{SurfaceFrame, Technique};
use crate::targets::Targets;

/// Maximum number of boxes in the background scene (fixed array in the uniform block).
pub const MAX_BOXES: usize = crate::shader_constants::MAX_BOXES as usize;
/// Maximum number of spheres in the background scene.
pub const MAX_SPHERES: usize = crate::shader_constants::MAX_SPHERES as usize;

/// Mirror of `Frame` in shaders_glsl/common.glsl (std140: only vec4/mat4 members).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct FrameUniforms {
    /// World → view matrix (column-major).
    pub view: [f32; 16],
    /// View → world matrix.
    pub inv_view: [f32; 16],
    /// Camera position (world), w = 1.
    pub eye: [f32; 4],
    /// x: focal length in output pixels, y: width, z: height, w: near plane distance.
    pub proj: [f32; 4],
    /// x: particle radius, y: fluid scale, z: thickness fixed-point units per world unit, w: particle count.
    pub fluid: [f32; 4],
    /// xyz: direction towards the sun (world, unit), w: intensity.
    pub sun: [f32; 4],
    /// x: ground height, y: checker tile size, z: 1 if the ground exists, w: fog distance.
    pub ground: [f32; 4],
    /// rgb: Beer–Lambert extinction per world unit.
    pub extinction: [f32; 4],
    /// rgb: colour I0 scattered out of the fluid, w: ambient light.
    pub fluid_color: [f32; 4],
    /// x: refraction α (px per world unit), y: β (max px), z: transparency γ, w: specular k_s.
    pub shading: [f32; 4],
    /// x: shininess, y: F0, z: sky reflection on/off, w: 1 when a sky cube map is loaded.
    pub shading2: [f32; 4],
    /// x: number of background boxes, y: of spheres.
    pub box_count: [f32; 4],
    /// Minimum corners of the background boxes (world).
    pub box_min: [[f32; 4]; MAX_BOXES],
    /// Maximum corners of the background boxes (world).
    pub box_max: [[f32; 4]; MAX_BOXES],
    /// The background's spheres: centre (world), radius.
    pub spheres: [[f32; 4]; MAX_SPHERES],
}

const _: () = assert!(std::mem::size_of::<FrameUniforms>() == 2 * 64 + 10 * 16 + 2 * 16 * MAX_BOXES + 16 * MAX_SPHERES);

impl FrameUniforms {
    /// Fill the block from the view and the settings.
    pub fn new(v: &View, s: &Settings, count: u32) -> FrameUniforms {
        let view: Mat4 = v.camera.view();
        let inv = view.inverse();
        let sun = Vec3::from(s.background.sun_dir).normalize_or(Vec3::Y);
        let ext = Vec3::from(s.composite.extinction) * s.composite.extinction_scale;
        let mut u = FrameUniforms {
            view: view.to_cols_array(),
            inv_view: inv.to_cols_array(),
            eye: v.camera.eye.extend(1.0).to_array(),
            proj: [v.camera.focal_px(v.height), v.width as f32, v.height as f32, v.camera.near],
            // Thickness fixed point: 1024 units per particle radius.
            fluid: [s.radius, s.fluid_scale, 1024.0 / s.radius, count as f32],
            sun: sun.extend(s.background.sun_intensity).to_array(),
            ground: [v.env.ground_y, v.env.tile, v.env.ground as u32 as f32, v.env.fog],
            extinction: ext.extend(0.0).to_array(),
            fluid_color: [
                s.composite.fluid_color[0],
                s.composite.fluid_color[1],
                s.composite.fluid_color[2],
                s.composite.ambient,
            ],
            shading: [
                s.composite.refraction_alpha,
                s.composite.refraction_beta,
                s.composite.transparency_gamma,
                s.composite.specular,
            ],
            shading2: [
                s.composite.shininess,
                s.composite.f0,
                s.composite.reflect_sky as u32 as f32,
                v.env.sky_cube as u32 as f32,
            ],
            box_count: [v.env.boxes.len().min(MAX_BOXES) as f32, v.env.spheres.len().min(MAX_SPHERES) as f32, 0.0, 0.0],
            box_min: [[0.0; 4]; MAX_BOXES],
            box_max: [[0.0; 4]; MAX_BOXES],
            spheres: [[0.0; 4]; MAX_SPHERES],
        };
        for (k, (c, r)) in v.env.spheres.iter().take(MAX_SPHERES).enumerate() {
            u.spheres[k] = c.extend(*r).to_array();
        }
        for (k, (lo, hi)) in v.env.boxes.iter().take(MAX_BOXES).enumerate() {
            u.box_min[k] = lo.extend(0.0).to_array();
            u.box_max[k] = hi.extend(0.0).to_array();
        }
        u
    }
}

use crate::gpu::recording::{Part, Recording};
use crate::passes::{FrameInfo, Passes};

/// Every pass name in frame order — the shared frame passes, the surface techniques' after `splat` and the
/// built-in effects' before `normals` (timestamp keys, JSON keys, `--timings` rows).
pub fn pass_names() -> &'static [&'static str] {
    static NAMES: std::sync::LazyLock<Vec<&'static str>> = std::sync::LazyLock::new(|| {
        let mut names = crate::passes::PASS_NAMES.to_vec();
        let at = names.iter().position(|n| *n == crate::passes::splat::NAME).map_or(names.len(), |k| k + 1);
        names.splice(at..at, crate::surface::PASS_NAMES.iter().copied());
        let at = names.iter().position(|n| *n == crate::passes::normals::NAME).unwrap_or(names.len());
        names.splice(at..at, crate::effect::BUILT_IN.iter().copied());
        names
    });
    &NAMES
}
use crate::view::View;

/// What `record_frame` produced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RecordedFrame {
    /// Which image holds the smoothed depth (at fluid resolution).
    pub smoothed: crate::passes::filter::Output,
}

/// Everything one frame is recorded from.
pub struct FrameInputs<'a> {
    /// Every pass.
    pub passes: &'a Passes,
    /// The frame's images.
    pub targets: &'a Targets,
    /// The frame uniform block.
    pub frame: &'a Buffer,
    /// The particle buffer: fluid particles, their motions, diffuse particles.
    pub particles: FrameParticles<'a>,
    /// The surface technique the settings name, its resources prepared.
    pub surface: &'a dyn Technique,
    /// The effects, their images prepared.
    pub effects: &'a Effects,
    /// Their layers in the composite, in order (`Effects::layers`).
    pub layers: &'a [crate::layer::Layer<'a>],
    /// The scene behind the fluid.
    pub background: &'a Background,
    /// The background images still show this view: the `background` pass is skipped.
    pub background_cached: bool,
    /// The frame's settings.
    pub settings: &'a Settings,
    /// Facts about this frame's camera.
    pub info: &'a FrameInfo,
}

/// THE FRAME: every pass in order, with the part (queue) beside it, each given the images it reads and writes;
/// each pass derives its own barriers from its slots, and the cross-queue waits of a split frame are derived
/// from what each part touched (`gpu::schedule`), so nothing here synchronises. The surface technique records
/// its own passes (`crate::surface`): what `thickness` needs first (grids, kernels), then the fluid's depth.
/// The effects (`crate::effect`) record before the normals, give them their detail (the noise's waves) and give the
/// composite its layers.
/// Optional steps: `background` (skipped while the view and scene stand), `upsample` (`fluid_scale` < 1), each
/// effect (while it draws: `noise` with `[noise] enabled`, `diffuse` with `[diffuse] enabled` and something to draw).
pub fn record_frame(rec: &mut Recording, f: &FrameInputs) -> Result<RecordedFrame> {
    use Part::*;
    let (p, t, s, frame) = (f.passes, f.targets, f.settings, f.frame);
    let sky = &f.background.sky;
    if !f.background_cached {
        p.background.record(rec.part(Async), frame, sky, f.background.geometry(), &t.scene_color, &t.scene_depth);
    }
    let particles = (f.particles.buffer, f.particles.count);
    let surface = SurfaceFrame { passes: p, targets: t, frame, particles, settings: s, info: f.info };
    let kernels = f.surface.record_kernels(rec, &surface);
    // Isolated particles still add thickness: with them the grid (built on the CPU then) leaves it out, so the thickness
    // keeps the spheres of every particle.
    let th = kernels.filter(|k| k.all_particles);
    let (th_particles, th_count) = th.map_or(particles, |k| (k.points, k.count));
    let th_kernels = th.map(|k| (k.aniso, k.stretch));
    let (accum, blur) = (&t.thickness_accum, s.thickness.blur_px);
    p.thickness.record(
        rec.part(Async),
        frame,
        th_particles,
        th_count,
        &t.scene_depth,
        accum,
        &t.thickness,
        blur,
        th_kernels,
    );
    let ctx = rec.part(Fluid);
    f.surface.record_depth(ctx, &surface, kernels)?;
    let smoothed = p.filter.record(ctx, frame, &t.depth, t.ping_pong(), &s.filter, s.radius, f.info);
    let fluid_depth = t.smoothed(smoothed);
    let depth = match &t.depth_full {
        Some(full) => {
            p.upsample.record(ctx, frame, fluid_depth, full, s.normals.edge * s.radius);
            full
        }
        None => fluid_depth,
    };
    let scene_depth = &t.scene_depth;
    let effect = EffectFrame { frame, particles: f.particles, depth, scene_depth, settings: s };
    f.effects.record(ctx, &effect);
    p.normals.record(ctx, frame, depth, &t.normals, s.normals.edge * s.radius, f.effects.detail(s)?);
    let ctx = rec.part(Shade);
    p.ssr.record(ctx, frame, depth, &t.normals, &t.scene_depth, &t.ssr, &s.ssr, s.radius);
    let inputs = CompositeInputs {
        scene_color: &t.scene_color,
        scene_depth: &t.scene_depth,
        depth,
        normals: &t.normals,
        thickness: &t.thickness,
        ssr: &t.ssr,
        sky,
    };
    p.composite.record(ctx, frame, &inputs, f.layers, &t.final_color)?;
    Ok(RecordedFrame { smoothed })
}
