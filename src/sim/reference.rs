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
    let h2 = u.kern[0];
    let lists: Vec<Vec<usize>> =
        (0..n).map(|i| (0..n).filter(|&j| j != i && (p[i] - p[j]).length_squared() < h2).collect()).collect();
    let mut density = vec![0.0; n];
    for _ in 0..iterations {
        let mut lambda = vec![0.0; n];
        for i in 0..n {
            let (mut w, mut grad_i, mut sum2) = (poly6(u, 0.0), Vec3::ZERO, 0.0);
            for &j in &lists[i] {
                let r = p[i] - p[j];
                w += poly6(u, r.length_squared());
                let gr = vol * spiky_grad(u, r);
                grad_i += gr;
                sum2 += gr.length_squared();
            }
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
    let out_v = (0..n)
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
    (p, out_v, density)
}
