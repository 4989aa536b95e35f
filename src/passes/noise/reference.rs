//! The CPU reference of noise.glsl and noise.comp, operation for operation (f32), for the tests.
use super::{Params, UNITS};

/// NOISE_DEEP of noise.glsl.
pub const DEEP: f32 = crate::shader_constants::NOISE_DEEP;

/// lowbias32 (noise_hash).
pub fn hash(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// NOISE_2D_RMS of noise.glsl.
pub const RMS_2D: f32 = crate::shader_constants::NOISE_2D_RMS;

fn grad(h: u32, f: [f32; 2]) -> f32 {
    (if h & 1 == 0 { f[0] } else { -f[0] }) + (if h & 2 == 0 { f[1] } else { -f[1] })
}

fn mix(a: f32, b: f32, t: f32) -> f32 {
    a * (1.0 - t) + b * t
}

/// noise_perlin: 2D gradient noise with the lattice's gradients picked by `seed`.
pub fn perlin(p: [f32; 2], seed: u32) -> f32 {
    let i = p.map(f32::floor);
    let f = [p[0] - i[0], p[1] - i[1]];
    let c = i.map(|x| x as i32);
    let w = f.map(|f| f * f * f * (f * (f * 6.0 - 15.0) + 10.0));
    let x0 = (c[0] as u32).wrapping_mul(0x8da6_b343);
    let x1 = x0.wrapping_add(0x8da6_b343);
    let y0 = (c[1] as u32).wrapping_mul(0xd816_3841).wrapping_add(seed);
    let y1 = y0.wrapping_add(0xd816_3841);
    let a = grad(hash(x0.wrapping_add(y0)), f);
    let b = grad(hash(x1.wrapping_add(y0)), [f[0] - 1.0, f[1]]);
    let e = grad(hash(x0.wrapping_add(y1)), [f[0], f[1] - 1.0]);
    let g = grad(hash(x1.wrapping_add(y1)), [f[0] - 1.0, f[1] - 1.0]);
    mix(mix(a, b, w[0]), mix(e, g, w[0]), w[1])
}

/// noise_offset.
pub fn offset(id: u32) -> [f32; 3] {
    let s = hash(id);
    [(hash(s) & 1023) as f32 * 0.25, (hash(s ^ 1) & 1023) as f32 * 0.25, (hash(s ^ 2) & 1023) as f32 * 0.25]
}

/// noise_sprite.
pub fn sprite(uv: [f32; 2], freq: f32, o: [f32; 3]) -> f32 {
    let q = [uv[0] * freq + o[0], uv[1] * freq + o[1]];
    let seed = ((o[2] * 4.0) as u32).wrapping_mul(0x9e37_79b9);
    RMS_2D * (perlin(q, seed) + 0.5 * perlin([2.0 * q[0] + 17.0, 2.0 * q[1] + 17.0], seed ^ 0x5bd1_e995))
}

/// noise_amplitude.
pub fn amplitude(accel: f32, p: &Params) -> f32 {
    let (e0, e1) = (0.5 * p.threshold, 1.5 * p.threshold);
    let t = ((accel - e0) / (e1 - e0)).clamp(0.0, 1.0);
    p.calm + (p.turbulent - p.calm) * (t * t * (3.0 - 2.0 * t))
}

/// One particle as noise.comp sees it: view-space centre, id, |Δv|/Δt.
pub struct NoiseParticle {
    /// View-space centre.
    pub c: [f32; 3],
    /// Its id.
    pub id: u32,
    /// |Δv| / Δt.
    pub accel: f32,
}

/// A sprite as noise_sprite_of places it on a `width`×`height` depth image (level 0): eye depth `z`, centre and
/// radius `rr` (pixels), its pixel rectangle [lo, hi] (clipped; empty when lo > hi); None when the particle is
/// behind the near plane or lies deeper than DEEP falloffs plus the sprite's radius below the surface at its
/// centre. Shared by [`accumulate`] and [`work`].
struct Placed {
    z: f32,
    centre: [f32; 2],
    rr: f32,
    lo: [i64; 2],
    hi: [i64; 2],
}

#[allow(clippy::too_many_arguments)]
fn place(
    pt: &NoiseParticle,
    depth: &[f32],
    width: usize,
    height: usize,
    f: f32,
    r: f32,
    near: f32,
    p: &Params,
) -> Option<Placed> {
    let z = -pt.c[2];
    if z <= near {
        return None;
    }
    let centre = [0.5 * width as f32 + f * pt.c[0] / z - 0.5, 0.5 * height as f32 - f * pt.c[1] / z - 0.5];
    let rr = f * p.size * r / z;
    let lo = [(centre[0] - rr).ceil().max(0.0) as i64, (centre[1] - rr).ceil().max(0.0) as i64];
    let hi = [
        ((centre[0] + rr).floor() as i64).min(width as i64 - 1),
        ((centre[1] + rr).floor() as i64).min(height as i64 - 1),
    ];
    let mid = [
        (centre[0].round() as i64).clamp(0, width as i64 - 1) as usize,
        (centre[1].round() as i64).clamp(0, height as i64 - 1) as usize,
    ];
    let dc = depth[mid[1] * width + mid[0]];
    if dc < 1e30 && z - dc > (DEEP * p.falloff + p.size) * r {
        return None;
    }
    Some(Placed { z, centre, rr, lo, hi })
}

/// The accumulator noise.comp fills for `particles` over a `width`×`height` depth image (row-major, +inf =
/// no fluid), focal `f` (pixels), radius `r`, near plane `near`: fixed-point sums, as i32.
#[allow(clippy::too_many_arguments)]
pub fn accumulate(
    particles: &[NoiseParticle],
    depth: &[f32],
    width: usize,
    height: usize,
    f: f32,
    r: f32,
    near: f32,
    p: &Params,
) -> Vec<i32> {
    let mut acc = vec![0i32; width * height];
    let inv_fall = 1.0 / (p.falloff * r);
    for pt in particles {
        let Some(Placed { z, centre, rr, lo, hi }) = place(pt, depth, width, height, f, r, near, p) else {
            continue;
        };
        let amp = amplitude(pt.accel, p);
        let o = offset(pt.id);
        for y in lo[1]..=hi[1] {
            for x in lo[0]..=hi[0] {
                let uv = [(x as f32 - centre[0]) / rr, (y as f32 - centre[1]) / rr];
                let q = uv[0] * uv[0] + uv[1] * uv[1];
                if q > 1.0 {
                    continue;
                }
                let d = depth[y as usize * width + x as usize];
                if d >= 1e30 {
                    continue;
                }
                let below = (z - d) * inv_fall;
                if below > DEEP {
                    continue;
                }
                let v = amp * (-2.0 * q).exp() * sprite(uv, p.frequency, o) * (-below * below).exp();
                let k = y as usize * width + x as usize;
                acc[k] = acc[k].wrapping_add((v * UNITS).round() as i32);
            }
        }
    }
    acc
}

/// The reference's work: the pixels of every sprite's rectangle not culled at its centre (what noise.comp
/// visited per particle before its level of detail), to compare [`NoiseWork::texels`] with.
#[allow(clippy::too_many_arguments)]
pub fn work(
    particles: &[NoiseParticle],
    depth: &[f32],
    width: usize,
    height: usize,
    f: f32,
    r: f32,
    near: f32,
    p: &Params,
) -> u64 {
    particles
        .iter()
        .filter_map(|pt| place(pt, depth, width, height, f, r, near, p))
        .filter(|s| s.lo[0] <= s.hi[0] && s.lo[1] <= s.hi[1])
        .map(|s| ((s.hi[0] - s.lo[0] + 1) * (s.hi[1] - s.lo[1] + 1)) as u64)
        .sum()
}
