//! A CPU reference of one PBF step with the same equations and the same uniform block as the GPU stages
//! (sim_common.glsl and the sim_*.comp shaders), with brute-force neighbour loops: the tests hold the GPU
//! solver to it. Slow (O(n²)); for small sets only. Like the GPU (Macklin & Müller, Alg. 1), a step lists
//! every particle's neighbours (within h) once, at the predicted positions, and every later loop uses the list.

use glam::Vec3;

use super::constants::SimUniforms;
use super::sdf::{push_out, Sdf};

fn v3(a: [f32; 4]) -> Vec3 {
    Vec3::new(a[0], a[1], a[2])
}

/// sim_common.glsl's poly6 with the block's constants.
fn poly6(u: &SimUniforms, r2: f32) -> f32 {
    if r2 >= u.kern[0] {
        return 0.0;
    }
    let d = u.kern[0] - r2;
    u.kern[1] * d * d * d
}

/// sim_common.glsl's spiky gradient.
fn spiky_grad(u: &SimUniforms, r: Vec3) -> Vec3 {
    let l = r.length();
    let h = u.hi_h[3];
    if l >= h || l < 1e-9 * h {
        return Vec3::ZERO;
    }
    let a = h - l;
    (u.kern[2] * a * a / l) * r
}

/// sim_common.glsl's collide(), with the mesh collider when there is one.
pub fn collide(u: &SimUniforms, sdf: Option<&Sdf>, mut x: Vec3) -> Vec3 {
    let r = u.visc[2];
    for k in 0..u.counts[1] as usize {
        let (a, b) = (u.colliders[2 * k], u.colliders[2 * k + 1]);
        match (a[3] + 0.5) as u32 {
            1 => {
                let d = x - v3(a);
                let l = d.length();
                let big_r = b[0] + r;
                if l < big_r {
                    x = v3(a) + if l > 1e-9 { d / l } else { Vec3::Y } * big_r;
                }
            }
            2 => {
                let d = x - v3(a);
                let e = v3(b) + r;
                let q = e - d.abs();
                if q.min_element() > 0.0 {
                    let s = Vec3::select(d.cmpge(Vec3::ZERO), Vec3::ONE, -Vec3::ONE);
                    if q.x <= q.y && q.x <= q.z {
                        x.x = a[0] + s.x * e.x;
                    } else if q.y <= q.z {
                        x.y = a[1] + s.y * e.y;
                    } else {
                        x.z = a[2] + s.z * e.z;
                    }
                }
            }
            3 => {
                let s = v3(a).dot(x) - (b[0] + r);
                if s < 0.0 {
                    x -= s * v3(a);
                }
            }
            _ => {}
        }
    }
    if let Some(sdf) = sdf {
        x = push_out(sdf, x, r);
    }
    x.clamp(v3(u.lo_dt), v3(u.hi_h))
}

/// sim_common.glsl's scorr_pow (n = the uniform block's counts.w).
fn scorr_pow(u: &SimUniforms, x: f32) -> f32 {
    scorr_pow_n(u.counts[3], x)
}

/// xⁿ for n = 1..15 by squaring, the shader's products in the same order.
pub fn scorr_pow_n(n: u32, x: f32) -> f32 {
    let mut p = if n & 1 != 0 { x } else { 1.0 };
    let mut b = x * x;
    if n & 2 != 0 {
        p *= b;
    }
    b *= b;
    if n & 4 != 0 {
        p *= b;
    }
    b *= b;
    if n & 8 != 0 {
        p *= b;
    }
    p
}

/// sim_common.glsl's wall_f: the missing half-space mass F(y) and A(y) = −F'(y).
fn wall_f(u: &SimUniforms, y: f32) -> (f32, f32) {
    let h = u.hi_h[3];
    let y = y.clamp(0.0, h);
    let h2 = h * h;
    let q = h2 - y * y;
    let c = 0.25 * std::f32::consts::PI * u.kern[1];
    let a = c * q * q * q * q;
    let y2 = y * y;
    let gy = y
        * (h2 * h2 * h2 * h2 - 4.0 / 3.0 * h2 * h2 * h2 * y2 + 6.0 / 5.0 * h2 * h2 * y2 * y2
            - 4.0 / 7.0 * h2 * y2 * y2 * y2
            + y2 * y2 * y2 * y2 / 9.0);
    let gh = h * h2 * h2 * h2 * h2 * (1.0 - 4.0 / 3.0 + 6.0 / 5.0 - 4.0 / 7.0 + 1.0 / 9.0);
    (c * (gh - gy), a)
}

/// sim_common.glsl's wall_density: Σ F over the container's faces and its gradient.
pub fn wall_density(u: &SimUniforms, x: Vec3) -> (f32, Vec3) {
    let lo = v3(u.lo_dt) - u.visc[2];
    let hi = v3(u.hi_h) + u.visc[2];
    let (mut f, mut g) = (0.0, Vec3::ZERO);
    for k in 0..3 {
        let (a, da) = wall_f(u, x[k] - lo[k]);
        f += a;
        g[k] -= da;
        let (b, db) = wall_f(u, hi[k] - x[k]);
        f += b;
        g[k] += db;
    }
    (f, g)
}

/// sim_velocity.comp's static friction against the container's faces: velocity `vel` of a particle ending at
/// `xs`, whose velocity after gravity was `vp`.
pub fn wall_friction(u: &SimUniforms, xs: Vec3, mut vel: Vec3, vp: Vec3) -> Vec3 {
    let mu = u.wall[0];
    for k in 0..3 {
        let side = if xs[k] <= u.lo_dt[k] {
            1.0
        } else if xs[k] >= u.hi_h[k] {
            -1.0
        } else {
            0.0
        };
        let mut vt = vel;
        vt[k] = 0.0;
        let push = side * (vel[k] - vp[k]);
        if side != 0.0 && push > 0.0 && vt.length_squared() <= mu * mu * push * push {
            vel -= vt;
        }
    }
    vel
}

/// Every particle's neighbours within h at positions `p` (brute force: sim_neighbours.comp's lists, for a step).
fn neighbour_lists(u: &SimUniforms, p: &[Vec3]) -> Vec<Vec<usize>> {
    let h2 = u.kern[0];
    (0..p.len()).map(|i| (0..p.len()).filter(|&j| j != i && (p[i] - p[j]).length_squared() < h2).collect()).collect()
}

/// Particle i's sums over its neighbours `list` at positions `p`, as sim_density and sim_dfsph_alpha take them:
/// Σ W_poly6 (itself included), Σ V ∇W_spiky and Σ |V ∇W_spiky|².
fn kernel_sums(u: &SimUniforms, p: &[Vec3], list: &[usize], i: usize) -> (f32, Vec3, f32) {
    let vol = u.kern[3];
    let (mut w, mut grad, mut sum2) = (poly6(u, 0.0), Vec3::ZERO, 0.0);
    for &j in list {
        let r = p[i] - p[j];
        w += poly6(u, r.length_squared());
        let gr = vol * spiky_grad(u, r);
        grad += gr;
        sum2 += gr.length_squared();
    }
    (w, grad, sum2)
}

/// The end every step shares (sim_velocity, sim_vorticity, sim_viscosity): v = (p − x)/Δt with the container's
/// static friction (`v_pred`: the velocity after gravity), then vorticity confinement and XSPH over `lists`.
fn end_of_step(u: &SimUniforms, lists: &[Vec<usize>], x: &[Vec3], p: &[Vec3], v: &[Vec3]) -> Vec<Vec3> {
    let n = x.len();
    let dt = u.lo_dt[3];
    let vol = u.kern[3];
    let vel: Vec<Vec3> = (0..n).map(|i| wall_friction(u, p[i], (p[i] - x[i]) / dt, v[i])).collect();
    let omega: Vec<Vec3> = (0..n)
        .map(|i| {
            let mut w = Vec3::ZERO;
            for &j in &lists[i] {
                w += (vel[j] - vel[i]).cross(-spiky_grad(u, p[i] - p[j]));
            }
            w * vol
        })
        .collect();
    let out_v: Vec<Vec3> = (0..n)
        .map(|i| {
            let (mut eta, mut xsph) = (Vec3::ZERO, Vec3::ZERO);
            for &j in &lists[i] {
                let r = p[i] - p[j];
                eta += (omega[j].length() - omega[i].length()) * spiky_grad(u, r);
                xsph += (vel[j] - vel[i]) * poly6(u, r.length_squared());
            }
            eta *= vol;
            let mut vi = vel[i] + u.visc[0] * vol * xsph;
            let le = eta.length();
            if le > 1e-9 && u.visc[1] > 0.0 {
                vi += dt * u.visc[1] * (eta / le).cross(omega[i]);
            }
            vi
        })
        .collect();
    out_v
}

/// One step of `iterations` solver iterations from positions `x` and velocities `v`: the new positions,
/// velocities and the densities of the last iteration.
pub fn step(
    u: &SimUniforms,
    sdf: Option<&Sdf>,
    iterations: u32,
    x: &[Vec3],
    v: &[Vec3],
) -> (Vec<Vec3>, Vec<Vec3>, Vec<f32>) {
    let n = x.len();
    let dt = u.lo_dt[3];
    let g = v3(u.gravity_mass);
    let vol = u.kern[3];
    let v: Vec<Vec3> = v.iter().map(|v| *v + dt * g).collect();
    let mut p: Vec<Vec3> = x.iter().zip(&v).map(|(x, v)| collide(u, sdf, *x + dt * *v)).collect();
    // Neighbour lists at the predicted positions, fixed for the step (sim_neighbours.comp).
    let lists = neighbour_lists(u, &p);
    let mut density = vec![0.0; n];
    for _ in 0..iterations {
        let mut lambda = vec![0.0; n];
        for i in 0..n {
            let (w, mut grad_i, sum2) = kernel_sums(u, &p, &lists[i], i);
            let (fw, gw) = wall_density(u, p[i]);
            grad_i += gw;
            let rho = u.gravity_mass[3] * w + u.solver[0] * fw;
            let c = (rho / u.solver[0] - 1.0).max(0.0);
            lambda[i] = -c / (sum2 + grad_i.length_squared() + u.solver[1]);
            density[i] = rho;
        }
        p = (0..n)
            .map(|i| {
                let mut dp = Vec3::ZERO;
                for &j in &lists[i] {
                    let r = p[i] - p[j];
                    let s = -u.solver[2] * scorr_pow(u, poly6(u, r.length_squared()) * u.solver[3]);
                    dp += (lambda[i] + lambda[j] + s) * spiky_grad(u, r);
                }
                collide(u, sdf, p[i] + vol * dp + lambda[i] * wall_density(u, p[i]).1)
            })
            .collect();
    }
    let out_v = end_of_step(u, &lists, x, &p, &v);
    (p, out_v, density)
}

/// What a DFSPH solve did ([`dfsph_step`]): corrections per solve (divergence-free, constant-density) and the
/// average error each ended at.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DfsphSolves {
    /// Corrections of the divergence-free and the constant-density solve (the warm start not counted).
    pub corrections: [u32; 2],
    /// The average error each solve ended at.
    pub error: [f32; 2],
}

/// One DFSPH step (src/sim/dfsph.rs and the sim_dfsph_*.comp shaders; Bender & Koschier 2017) from rest of the
/// warm starts (a first step: no κ carried), with brute-force neighbour lists at x: v* = v + Δt g; ρ̂ and the
/// factor; the divergence-free solve then the constant-density solve, each a Jacobi iteration of κ from the
/// density change rate until the average error is within `eta` (fractions: divergence, density) after at least
/// 1 and 2 corrections, or `max_iter` corrections; x + Δt v with the collisions; then PBF's end of step. Returns
/// the new positions, velocities, the densities (kg/m³, ρ̂ ρ0) and what the solves did.
pub fn dfsph_step(
    u: &SimUniforms,
    sdf: Option<&Sdf>,
    eta: [f32; 2],
    max_iter: u32,
    x: &[Vec3],
    v: &[Vec3],
) -> (Vec<Vec3>, Vec<Vec3>, Vec<f32>, DfsphSolves) {
    let n = x.len();
    let dt = u.lo_dt[3];
    let g = v3(u.gravity_mass);
    let vol = u.kern[3];
    let v_pred: Vec<Vec3> = v.iter().map(|v| *v + dt * g).collect();
    let lists = neighbour_lists(u, x);
    // ρ̂ and the factor (sim_dfsph_alpha).
    let (mut rho, mut factor) = (vec![0.0f32; n], vec![0.0f32; n]);
    for i in 0..n {
        let (w, gsum, g2) = kernel_sums(u, x, &lists[i], i);
        let (fw, gw) = wall_density(u, x[i]);
        rho[i] = vol * w + fw;
        let s1 = gsum + gw;
        let s = s1.length_squared() + g2;
        factor[i] = if s > 1e-6 { -1.0 / s } else { 0.0 };
    }
    let mut vel = v_pred.clone();
    let mut solves = DfsphSolves::default();
    for (solve, min_iter) in [(0usize, 1u32), (1, 2)] {
        // The density change rate and κ (sim_dfsph_rate), the average error.
        let rate = |vel: &[Vec3]| -> (Vec<f32>, f32) {
            let mut kappa = vec![0.0f32; n];
            let mut sum = 0.0f32;
            for i in 0..n {
                let mut d = 0.0;
                for &j in &lists[i] {
                    d += (vel[i] - vel[j]).dot(spiky_grad(u, x[i] - x[j]));
                }
                d = vol * d + vel[i].dot(wall_density(u, x[i]).1);
                let err = if solve == 1 {
                    let adv = (rho[i] + dt * d).max(1.0);
                    kappa[i] = (adv - 1.0) * factor[i] / (dt * dt);
                    adv - 1.0
                } else {
                    let d = if lists[i].len() < 20 { 0.0 } else { d.max(0.0) };
                    kappa[i] = d * factor[i] / dt;
                    d * dt
                };
                sum += err;
            }
            (kappa, sum / n.max(1) as f32)
        };
        // One Jacobi correction (sim_dfsph_update).
        let update = |vel: &mut Vec<Vec3>, kappa: &[f32]| {
            let dv: Vec<Vec3> = (0..n)
                .map(|i| {
                    let mut s = Vec3::ZERO;
                    for &j in &lists[i] {
                        s += (kappa[i] + kappa[j]) * spiky_grad(u, x[i] - x[j]);
                    }
                    dt * (vol * s + kappa[i] * wall_density(u, x[i]).1)
                })
                .collect();
            for (v, d) in vel.iter_mut().zip(dv) {
                *v += d;
            }
        };
        let (mut kappa, mut avg) = rate(&vel);
        let mut done = 0u32;
        while !((avg <= eta[solve] && done >= min_iter) || done >= max_iter) {
            update(&mut vel, &kappa);
            done += 1;
            (kappa, avg) = rate(&vel);
        }
        solves.corrections[solve] = done;
        solves.error[solve] = avg;
    }
    let p: Vec<Vec3> = (0..n).map(|i| collide(u, sdf, x[i] + dt * vel[i])).collect();
    let out_v = end_of_step(u, &lists, x, &p, &v_pred);
    let density = rho.iter().map(|r| r * u.solver[0]).collect();
    (p, out_v, density, solves)
}
