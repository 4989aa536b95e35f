//! `normals` pass: discontinuity-aware view-space normals from the smoothed depth, octahedral-packed, with an
//! effect's detail height field (the `noise` effect's small waves) added as slopes when one is given.
//! Shader: shaders_glsl/normals.comp (NORMALS_DETAIL: the variant with the detail).
use std::sync::Arc;

use crate::declare_program;
use crate::error::Result;
use crate::gpu::{groups_2d, Buffer, ComputeProgram, FrameCtx, Gpu, Image};
use crate::layer::Detail;
use crate::shaders;

/// The pass's one name (module, shader stem, debug label, timestamp key, JSON key): `normals`.
pub const NAME: &str = "normals";

/// Settings of the `normals` pass: the `[normals]` section of a settings file.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Depth jump, in particle radii, that the normals pass treats as a discontinuity.
    pub edge: f32,
}

impl Default for Params {
    fn default() -> Self {
        Params { edge: 2.0 }
    }
}

impl crate::section::Section for Params {
    fn name(&self) -> &'static str {
        NAME
    }

    fn check(&self) -> crate::section::Checked {
        crate::section::Keys(NAME).within("edge", self.edge, 0.0, 1e4)
    }
}

/// The pass: its compute programs (without and with a detail height field), built once per device.
pub struct Normals {
    prog: ComputeProgram<Push>,
    detailed: ComputeProgram<Push>,
}

/// Push constants of normals.comp.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Push {
    /// Depth jump (world units) above which a neighbour is on another surface.
    pub edge: f32,
    /// Scale of the detail's slopes ([`Detail::strength`]; 0 without one).
    pub strength: f32,
}

// Frame, depth → normals; with a detail, its heights after them.
declare_program!(pub PROGRAM: Push = compute(shaders::NORMALS, [Uniform, ImgRead, ImgOverwrite]));
declare_program!(pub DETAILED: Push = compute(shaders::NORMALS_DETAIL, [Uniform, ImgRead, ImgOverwrite, ImgRead]));

impl Normals {
    /// Build the pass's pipelines (their slot lists were checked against the shaders at compile time).
    pub fn new(gpu: &Arc<Gpu>) -> Result<Self> {
        Ok(Normals { prog: ComputeProgram::new(gpu, &PROGRAM)?, detailed: ComputeProgram::new(gpu, &DETAILED)? })
    }

    /// `edge`: depth jump (world units) above which a neighbour is on another surface; `detail`: the height field
    /// whose slopes perturb the normals, if an effect gives one.
    pub fn record(
        &self,
        ctx: &mut FrameCtx,
        frame: &Buffer,
        depth: &Image,
        normals: &Image,
        edge: f32,
        detail: Option<Detail>,
    ) {
        ctx.pass(NAME, |ctx| {
            let g = groups_2d(normals.extent.width, normals.extent.height, super::LOCAL_2D);
            let push = Push { edge, strength: detail.map_or(0.0, |d| d.strength) };
            match detail {
                None => self.prog.dispatch(ctx, &[frame.into(), depth.into(), normals.into()], &push, g),
                Some(d) => {
                    let res = [frame.into(), depth.into(), normals.into(), d.image.into()];
                    self.detailed.dispatch(ctx, &res, &push, g)
                }
            }
        });
    }
}

/// CPU mirror of `unpack_normal` in common.glsl (octahedral, 2 × snorm16).
pub fn unpack(u: u32) -> [f32; 3] {
    let sn = |v: u16| (v as i16 as f32 / 32767.0).clamp(-1.0, 1.0);
    let (ex, ey) = (sn(u as u16), sn((u >> 16) as u16));
    let mut n = [ex, ey, 1.0 - ex.abs() - ey.abs()];
    if n[2] < 0.0 {
        let (x, y) = (n[0], n[1]);
        n[0] = (1.0 - y.abs()) * if x >= 0.0 { 1.0 } else { -1.0 };
        n[1] = (1.0 - x.abs()) * if y >= 0.0 { 1.0 } else { -1.0 };
    }
    let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    [n[0] / l, n[1] / l, n[2] / l]
}
