//! GPU tests on lavapipe: each pass against an analytic or CPU reference, with validation and
//! synchronization validation on (any message fails the test).
// The CPU references mirror the shaders: `!(d < 1e30)` is true for +inf AND NaN (empty pixel), which is the point,
// and the filter references take the same parameter lists as the shaders' push constants.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::too_many_arguments)]

mod common;

use common::*;
use meniscus::effect::diffuse::DiffuseEffect;
use meniscus::effect::noise::NoiseEffect;
use meniscus::gpu::transfer::{read_f32, read_image, read_u32, upload_image};
use meniscus::gpu::FrameCtx;
use meniscus::named::Filter;
use meniscus::renderer::Renderer;

/// The frame's images for `v` and `s`, and its uniform block written, for tests that record passes one by one.
fn pass_targets(r: &mut Renderer, v: &meniscus::view::View, s: &meniscus::settings::Settings) {
    let desc = meniscus::targets::TargetsDesc::new(v.width, v.height, s, r.state().keeps_raw_depth());
    let t = meniscus::targets::Targets::new(r.state().gpu(), desc).unwrap();
    *r.parts_mut().targets = Some(t);
    let u = meniscus::frame::FrameUniforms::new(v, s, r.state().particles().count());
    r.parts_mut().uniforms.write(0, bytemuck::bytes_of(&u)).unwrap();
}

/// Render one frame whose passes count their own work (`FrameRequest::count_work`) and wait for it.
fn render_counted(
    r: &mut Renderer,
    v: &meniscus::view::View,
    s: &meniscus::settings::Settings,
) -> meniscus::Result<meniscus::timing::PassTimes> {
    let sub = r.submit(meniscus::renderer::FrameRequest::new(v, s).count_work())?;
    r.finish(sub)
}

/// One sphere of radius 0.5 at the origin, camera at z = 3: splat depth equals the exact ray–sphere entry.
#[test]
fn splat_depth_matches_analytic_sphere() {
    let gpu = gpu();
    let (w, h) = (96usize, 64usize);
    let v = view([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], w as u32, h as u32, 40.0);
    let mut s = settings(0.5);
    s.filter.method = Filter::None;
    let r = rendered(&gpu, &[[0.0, 0.0, 0.0]], &v, &s, true);
    let depth = read_f32(&gpu, &r.state().targets().unwrap().depth).unwrap();
    let f = v.camera.focal_px(h as u32) as f64;
    let (mut covered, mut max_err) = (0, 0f64);
    for y in 0..h {
        for x in 0..w {
            let got = depth[y * w + x];
            match ray_sphere(pixel_dir(x, y, w, h, f), [0.0, 0.0, -3.0], 0.5) {
                Some((d_in, _)) => {
                    assert!(got.is_finite(), "pixel ({x},{y}) should be covered");
                    max_err = max_err.max((got as f64 - d_in).abs());
                    covered += 1;
                }
                None => assert!(got.is_infinite(), "pixel ({x},{y}) should be empty, got {got}"),
            }
        }
    }
    assert!(covered > 300, "sphere covers {covered} pixels");
    assert!(max_err < 1e-4, "max depth error {max_err}");
    assert_clean(&gpu);
}

/// The near plane clamps: a sphere cut by the near plane reads exactly `near` where it is cut.
#[test]
fn splat_clamps_to_near_plane() {
    let gpu = gpu();
    let v = view([0.0, 0.0, 0.3], [0.0, 0.0, 0.0], 32, 32, 60.0);
    let mut s = settings(0.5);
    s.filter.method = Filter::None;
    let r = rendered(&gpu, &[[0.0, 0.0, 0.0]], &v, &s, true);
    let depth = read_f32(&gpu, &r.state().targets().unwrap().depth).unwrap();
    let centre = depth[16 * 32 + 16];
    assert!((centre - v.camera.near).abs() < 1e-6, "centre depth {centre}, near {}", v.camera.near);
    assert_clean(&gpu);
}

/// Thickness of one sphere = chord of each pixel ray = 2·r·(n·v) (Moritz eq. 3.6 with the exact normal).
#[test]
fn thickness_of_one_sphere_is_its_chord() {
    let gpu = gpu();
    let (w, h) = (64usize, 64usize);
    let v = view([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], w as u32, h as u32, 40.0);
    let mut s = settings(0.5);
    s.thickness.scale = 1.0;
    s.thickness.blur_px = 0;
    let r = rendered(&gpu, &[[0.0, 0.0, 0.0]], &v, &s, false);
    let t = read_f32(&gpu, &r.state().targets().unwrap().thickness).unwrap();
    let f = v.camera.focal_px(h as u32) as f64;
    let mut max_err = 0f64;
    for y in 0..h {
        for x in 0..w {
            let dir = pixel_dir(x, y, w, h, f);
            let len = (dir[0] * dir[0] + dir[1] * dir[1] + 1.0).sqrt();
            let want = ray_sphere(dir, [0.0, 0.0, -3.0], 0.5).map(|(a, b)| (b - a) * len).unwrap_or(0.0);
            max_err = max_err.max((t[y * w + x] as f64 - want).abs());
        }
    }
    // Fixed point: 1024 units per radius → 0.5/1024 per unit; plus float rounding.
    assert!(max_err < 1e-3, "max thickness error {max_err}");
    let centre = t[32 * w + 32] as f64;
    assert!((centre - 1.0).abs() < 5e-3, "centre thickness {centre} ≈ 2r");
    assert_clean(&gpu);
}

/// A box between camera and sphere: no thickness where the box hides the sphere.
#[test]
fn thickness_is_zero_behind_scene_geometry() {
    let gpu = gpu();
    let (w, h) = (64usize, 64usize);
    let mut v = view([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], w as u32, h as u32, 40.0);
    // A box covering the left half of the screen in front of the sphere.
    v.env.boxes = vec![(glam::Vec3::new(-5.0, -5.0, 0.8), glam::Vec3::new(0.0, 5.0, 1.0))];
    let mut s = settings(0.5);
    s.thickness.scale = 1.0;
    s.thickness.blur_px = 0;
    let r = rendered(&gpu, &[[0.0, 0.0, 0.0]], &v, &s, false);
    let t = read_f32(&gpu, &r.state().targets().unwrap().thickness).unwrap();
    // The sphere covers a disc of about 15 px radius around (32, 32); the box hides x < 32.
    for y in 26..38 {
        assert_eq!(t[y * w + 21], 0.0, "hidden pixel ({}, {y}) has thickness", 21);
        assert!(t[y * w + 42] > 0.0, "visible pixel (42, {y}) lacks thickness");
    }
    assert_clean(&gpu);
}

/// CPU reference of filter_bilateral.comp (one dispatch), same math.
fn bilateral_cpu(src: &[f32], w: usize, h: usize, f: f32, dir: (i32, i32), rho: f32, sr: f32, max_px: i32) -> Vec<f32> {
    let mut out = src.to_vec();
    for y in 0..h as i32 {
        for x in 0..w as i32 {
            let d = src[(y as usize) * w + x as usize];
            if !(d < 1e30) {
                continue;
            }
            let rpx = (rho * f / d).clamp(1.0, max_px as f32);
            let r = rpx.ceil() as i32;
            let sd = (rpx * 0.5).max(0.5);
            let kd = 1.0 / (2.0 * sd * sd);
            let kr = if sr > 0.0 { 1.0 / (2.0 * sr * sr) } else { 0.0 };
            let (mut sum, mut ws) = (d, 1.0f32);
            let mut tap = |qx: i32, qy: i32, dist2: f32| {
                if qx < 0 || qy < 0 || qx >= w as i32 || qy >= h as i32 {
                    return;
                }
                let dq = src[qy as usize * w + qx as usize];
                if !(dq < 1e30) {
                    return;
                }
                let dz = dq - d;
                let wt = (-dist2 * kd - dz * dz * kr).exp();
                sum += wt * dq;
                ws += wt;
            };
            if dir != (0, 0) {
                for i in -r..=r {
                    if i != 0 {
                        tap(x + i * dir.0, y + i * dir.1, (i * i) as f32);
                    }
                }
            } else {
                for j in -r..=r {
                    for i in -r..=r {
                        if i != 0 || j != 0 {
                            tap(x + i, y + j, (i * i + j * j) as f32);
                        }
                    }
                }
            }
            out[y as usize * w + x as usize] = sum / ws;
        }
    }
    out
}

/// Synthetic depth: a plane at depth 3 with bumps, a nearer disc (second surface), background corners.
fn bumpy_depth(w: usize, h: usize) -> Vec<f32> {
    let mut d = vec![f32::INFINITY; w * h];
    for y in 0..h {
        for x in 0..w {
            let (fx, fy) = (x as f32, y as f32);
            if fx + fy < 10.0 {
                continue; // background corner
            }
            let bump = 0.02 * ((fx * 1.7).sin() * (fy * 1.3).cos());
            let mut z = 3.0 + 0.004 * fx + bump;
            let (cx, cy) = (fx - 40.0, fy - 24.0);
            if cx * cx + cy * cy < 100.0 {
                z = 2.2 + bump; // a nearer surface overlapping the plane
            }
            d[y * w + x] = z;
        }
    }
    d
}

/// Run only the `filter` pass on `src` (a depth image of the view's size) and read the result back.
fn smooth_once(
    gpu: &std::sync::Arc<meniscus::gpu::Gpu>,
    v: &meniscus::view::View,
    s: &meniscus::settings::Settings,
    src: &[f32],
    its: u32,
) -> Vec<f32> {
    let mut r = Renderer::new(gpu).unwrap();
    *r.parts_mut().keep_raw_depth = true;
    pass_targets(&mut r, v, s);
    let t = r.state().targets().unwrap();
    upload_image(gpu, &t.depth, bytemuck::cast_slice(src)).unwrap();
    let out = gpu
        .one_shot(|cmd| {
            let mut ctx = FrameCtx::new(gpu, cmd, None);
            Ok(r.state().passes().filter.record_iterations(
                &mut ctx,
                r.state().uniforms(),
                &t.depth,
                t.ping_pong(),
                &s.filter,
                s.radius,
                its,
            ))
        })
        .unwrap();
    read_f32(gpu, t.smoothed(out)).unwrap()
}

#[test]
fn bilateral_separable_and_2d_match_cpu_reference() {
    let gpu = gpu();
    let (w, h) = (64usize, 48usize);
    let v = view([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], w as u32, h as u32, 40.0);
    let f = v.camera.focal_px(h as u32);
    for filter in [Filter::Bilateral, Filter::Bilateral2d, Filter::Gaussian] {
        let mut s = settings(0.05);
        s.filter.method = filter;
        s.filter.bilateral.iterations = 1;
        let src = bumpy_depth(w, h);
        let got = smooth_once(&gpu, &v, &s, &src, 0);
        let sr = if filter == Filter::Gaussian { 0.0 } else { s.filter.bilateral.sigma_range * s.radius };
        let rho = s.filter.radius * s.radius;
        let max_px = s.filter.max_px as i32;
        let want = match filter {
            Filter::Bilateral2d => bilateral_cpu(&src, w, h, f, (0, 0), rho, sr, max_px),
            _ => {
                let a = bilateral_cpu(&src, w, h, f, (1, 0), rho, sr, max_px);
                bilateral_cpu(&a, w, h, f, (0, 1), rho, sr, max_px)
            }
        };
        for i in 0..w * h {
            if want[i].is_infinite() {
                assert!(got[i].is_infinite(), "{filter:?}: background pixel {i} became fluid");
            } else {
                assert!((got[i] - want[i]).abs() < 1e-4, "{filter:?}: pixel {i}: gpu {} cpu {}", got[i], want[i]);
            }
        }
        assert_clean(&gpu);
    }
}

/// Normals of an analytic tilted plane and of a sphere, from depth.
#[test]
fn normals_of_plane_and_sphere() {
    let gpu = gpu();
    let (w, h) = (64usize, 64usize);
    let v = view([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], w as u32, h as u32, 40.0);
    let f = v.camera.focal_px(h as u32) as f64;
    let s = settings(0.05);
    let mut r = Renderer::new(&gpu).unwrap();
    pass_targets(&mut r, &v, &s);
    let t = r.state().targets().unwrap();
    // Plane through (0,0,−3) with view-space normal n: n·P = n·(0,0,−3).
    let n = {
        let n = [0.3f64, -0.2, 1.0];
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        [n[0] / l, n[1] / l, n[2] / l]
    };
    let mut depth = vec![0f32; w * h];
    let mut truth = vec![[0f64; 3]; w * h];
    for y in 0..h {
        for x in 0..w {
            let dir = pixel_dir(x, y, w, h, f);
            let sphere = ray_sphere(dir, [0.0, 0.0, -3.0], 0.6);
            if let (Some((d, _)), true) = (sphere, x >= w / 2) {
                // Right half: a sphere.
                let p = [dir[0] * d, dir[1] * d, dir[2] * d + 3.0];
                depth[y * w + x] = d as f32;
                truth[y * w + x] = [p[0] / 0.6, p[1] / 0.6, p[2] / 0.6];
            } else if x < w / 2 {
                let d = (n[2] * -3.0) / (n[0] * dir[0] + n[1] * dir[1] + n[2] * dir[2]);
                depth[y * w + x] = d as f32;
                truth[y * w + x] = n;
            } else {
                depth[y * w + x] = f32::INFINITY;
            }
        }
    }
    upload_image(&gpu, &t.depth, bytemuck::cast_slice(&depth)).unwrap();
    gpu.one_shot(|cmd| {
        let mut ctx = FrameCtx::new(&gpu, cmd, None);
        r.state().passes().normals.record(&mut ctx, r.state().uniforms(), &t.depth, &t.normals, 0.05, None);
        Ok(())
    })
    .unwrap();
    let words: Vec<u32> = bytemuck::pod_collect_to_vec(&read_image(&gpu, &t.normals).unwrap());
    let angle = |i: usize| {
        let g = meniscus::passes::normals::unpack(words[i]);
        let tr = truth[i];
        let c = g[0] as f64 * tr[0] + g[1] as f64 * tr[1] + g[2] as f64 * tr[2];
        c.clamp(-1.0, 1.0).acos().to_degrees()
    };
    let mut sphere_errs = vec![];
    for y in 2..h - 2 {
        for x in 2..w / 2 - 2 {
            assert!(angle(y * w + x) < 0.5, "plane normal off by {}° at ({x},{y})", angle(y * w + x));
        }
        for x in w / 2 + 2..w - 2 {
            let i = y * w + x;
            // Interior of the sphere: all 8 neighbours covered and facing the camera well.
            let interior = (0..9).all(|k| depth[(y + k / 3 - 1) * w + x + k % 3 - 1].is_finite());
            if interior && truth[i][2] > 0.3 {
                sphere_errs.push(angle(i));
            }
        }
    }
    sphere_errs.sort_by(f64::total_cmp);
    let median = sphere_errs[sphere_errs.len() / 2];
    let max = *sphere_errs.last().unwrap();
    assert!(median < 1.0 && max < 6.0, "sphere normal error median {median}°, max {max}°");
    // Empty pixels get 0.
    assert_eq!(words[w - 1], 0);
    assert_clean(&gpu);
}

/// The messenger really counts: an invalid call (a zero-sized buffer) is reported as an error.
#[test]
fn validation_messenger_counts_errors() {
    let gpu = gpu();
    let ci = ash::vk::BufferCreateInfo::default().size(0).usage(ash::vk::BufferUsageFlags::STORAGE_BUFFER);
    // SAFETY: deliberately invalid parameters, caught by the validation layer before the driver.
    if let Ok(b) = unsafe { gpu.device.create_buffer(&ci, None) } {
        unsafe { gpu.device.destroy_buffer(b, None) };
    }
    assert!(gpu.validation().errors() >= 1, "the validation layer reported nothing");
}

/// Behaviour of every filter on a bumpy tilted plane with a background border: background stays background,
/// bumps shrink (RMS deviation from the true plane drops), a perfectly flat plane stays flat.
#[test]
fn every_filter_smooths_bumps_keeps_background_and_flat_planes() {
    let gpu = gpu();
    let (w, h) = (96usize, 64usize);
    let v = view([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], w as u32, h as u32, 40.0);
    let f = v.camera.focal_px(h as u32) as f64;
    let r = 0.01f32;
    // Plane through (0,0,−3), slightly tilted; bumps of ±0.5 r with a period of ~4 px.
    let plane = |x: usize, y: usize| {
        let dir = pixel_dir(x, y, w, h, f);
        let n = [0.1f64, 0.05, 1.0];
        (n[2] * -3.0) / (n[0] * dir[0] + n[1] * dir[1] + n[2] * dir[2])
    };
    let make = |bumpy: bool| -> Vec<f32> {
        let mut d = vec![f32::INFINITY; w * h];
        for y in 8..h - 8 {
            for x in 8..w - 8 {
                let b = if bumpy { 0.5 * r as f64 * ((x as f64 * 1.6).sin() * (y as f64 * 1.3).cos()) } else { 0.0 };
                d[y * w + x] = (plane(x, y) + b) as f32;
            }
        }
        d
    };
    let rms = |d: &[f32]| {
        let mut s = 0.0;
        let mut n = 0;
        for y in 12..h - 12 {
            for x in 12..w - 12 {
                s += (d[y * w + x] as f64 - plane(x, y)).powi(2);
                n += 1;
            }
        }
        (s / n as f64).sqrt()
    };
    for filter in [Filter::Gaussian, Filter::Bilateral, Filter::Bilateral2d, Filter::CurvatureFlow, Filter::NarrowRange]
    {
        for bumpy in [true, false] {
            let mut s = settings(r);
            s.filter.method = filter;
            let src = make(bumpy);
            let its = meniscus::passes::filter::iterations_needed(&s.filter, s.radius, f as f32, 2.5);
            let got = smooth_once(&gpu, &v, &s, &src, its);
            for i in 0..w * h {
                assert_eq!(src[i].is_infinite(), got[i].is_infinite(), "{filter:?}: coverage changed at {i}");
            }
            let (before, after) = (rms(&src), rms(&got));
            if bumpy {
                assert!(after < 0.6 * before, "{filter:?}: bumps RMS {before:.2e} → {after:.2e}");
            } else {
                assert!(after < 0.05 * r as f64, "{filter:?}: flat plane moved by RMS {after:.2e}");
            }
        }
    }
    assert_clean(&gpu);
}

/// SSR against a CPU ray tracer: a flat mirror of fluid at y = 0 and a box standing behind it. Where the CPU
/// says the reflected ray hits the box's visible front face, the GPU's hit pixel is within 2 px of the
/// projection of the CPU hit point; where the CPU ray hits nothing, the GPU reports no hit.
#[test]
fn ssr_hits_match_cpu_ray_tracer() {
    use glam::{Vec3, Vec4Swizzles};
    let gpu = gpu();
    let (w, h) = (128usize, 96usize);
    let mut v = view([0.0, 1.0, 4.0], [0.0, 0.3, 0.0], w as u32, h as u32, 45.0);
    let (bmin, bmax) = (Vec3::new(-0.8, 0.0, -1.5), Vec3::new(0.8, 1.0, -1.0));
    v.env.boxes = vec![(bmin, bmax)];
    let mut s = settings(0.01);
    s.ssr.stride = 2.0;
    s.ssr.max_steps = 400;
    s.ssr.refine = 4;
    s.ssr.max_distance = 800.0;
    s.ssr.thickness = 5.0;
    let mut r = Renderer::new(&gpu).unwrap();
    pass_targets(&mut r, &v, &s);
    let view_m = v.camera.view();
    let inv = view_m.inverse();
    let f = v.camera.focal_px(h as u32) as f64;
    // Fluid: the plane y = 0 in front of the box (z > −1), as linear depth.
    let mut depth = vec![f32::INFINITY; w * h];
    for y in 0..h {
        for x in 0..w {
            let d = pixel_dir(x, y, w, h, f);
            let dw = inv.transform_vector3(Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32));
            if dw.y < 0.0 {
                let t = -v.camera.eye.y / dw.y;
                let p = v.camera.eye + dw * t;
                if p.z > -0.9 && p.x.abs() < 3.0 {
                    depth[y * w + x] = t;
                }
            }
        }
    }
    let t = r.state().targets().unwrap();
    upload_image(&gpu, &t.depth, bytemuck::cast_slice(&depth)).unwrap();
    gpu.one_shot(|cmd| {
        let mut ctx = FrameCtx::new(&gpu, cmd, None);
        r.state().passes().background.record(
            &mut ctx,
            r.state().uniforms(),
            &r.state().background().sky,
            r.state().background().geometry(),
            &t.scene_color,
            &t.scene_depth,
        );
        r.state().passes().normals.record(&mut ctx, r.state().uniforms(), &t.depth, &t.normals, 0.05, None);
        r.state().passes().ssr.record(
            &mut ctx,
            r.state().uniforms(),
            &t.depth,
            &t.normals,
            &t.scene_depth,
            &t.ssr,
            &s.ssr,
            s.radius,
        );
        Ok(())
    })
    .unwrap();
    let raw = read_image(&gpu, &t.ssr).unwrap();
    let hits: Vec<Option<[f32; 2]>> =
        bytemuck::pod_collect_to_vec::<u8, u32>(&raw).into_iter().map(meniscus::passes::ssr::decode).collect();
    let (mut checked, mut misses, mut bad) = (0, 0, vec![]);
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if !depth[i].is_finite() {
                continue;
            }
            let d = pixel_dir(x, y, w, h, f);
            let dw = inv.transform_vector3(Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32));
            let p = v.camera.eye + dw * depth[i];
            let rd = Vec3::new(dw.x, -dw.y, dw.z).normalize();
            // Ray against the box's front face z = bmax.z (the only face visible from the camera).
            let (gx, gy, ga) = match hits[i] {
                Some([u, v]) => (u * w as f32 - 0.5, v * h as f32 - 0.5, 1.0),
                None => (0.0, 0.0, 0.0),
            };
            let hit = if rd.z < 0.0 {
                let tt = (bmax.z - p.z) / rd.z;
                let q = p + rd * tt;
                (q.x > bmin.x && q.x < bmax.x && q.y > bmin.y && q.y < bmax.y).then_some(q)
            } else {
                None
            };
            match hit {
                Some(q) => {
                    let qv = (view_m * q.extend(1.0)).xyz();
                    let dq = -qv.z as f64;
                    let px = 0.5 * w as f64 + f * qv.x as f64 / dq - 0.5;
                    let py = 0.5 * h as f64 - f * qv.y as f64 / dq - 0.5;
                    // Skip grazing cases near the box's outline, where one pixel decides.
                    let inner = q.x.abs() < 0.75 && q.y > 0.05 && q.y < 0.95;
                    if inner && ga > 0.5 {
                        checked += 1;
                        let e = ((gx as f64 - px).powi(2) + (gy as f64 - py).powi(2)).sqrt();
                        if e > 2.0 {
                            bad.push((x, y, e));
                        }
                    } else if inner {
                        misses += 1;
                    }
                }
                None => {
                    if rd.y > 0.05 && rd.z > -0.2 {
                        assert!(ga == 0.0, "pixel ({x},{y}): reflected ray escapes but SSR reports a hit");
                    }
                }
            }
        }
    }
    assert!(checked > 200, "only {checked} pixels see the box in the mirror");
    assert!(misses * 50 < checked, "{misses} box reflections missed of {checked}");
    assert!(
        bad.len() * 100 < checked,
        "{} of {checked} hits off by > 2 px, e.g. {:?}",
        bad.len(),
        &bad[..bad.len().min(5)]
    );
    assert_clean(&gpu);
}

/// Upsampling never invents a depth between two separated surfaces, keeps background as background, and
/// interpolates inside a surface.
#[test]
fn upsample_never_lands_between_surfaces() {
    let gpu = gpu();
    let (w, h) = (64usize, 48usize);
    let v = view([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], w as u32, h as u32, 40.0);
    let mut s = settings(0.01);
    s.fluid_scale = 0.5;
    let mut r = Renderer::new(&gpu).unwrap();
    pass_targets(&mut r, &v, &s);
    let t = r.state().targets().unwrap();
    let (lw, lh) = (t.depth.extent.width as usize, t.depth.extent.height as usize);
    assert_eq!((lw, lh), (32, 24));
    // Left: a near surface sloping from 2.0; right: a far one at 3.0; a background band at the top.
    let low: Vec<f32> = (0..lw * lh)
        .map(|i| {
            let (x, y) = (i % lw, i / lw);
            if y < 4 {
                f32::INFINITY
            } else if x < 13 {
                2.0 + 0.002 * x as f32
            } else {
                3.0
            }
        })
        .collect();
    upload_image(&gpu, &t.depth, bytemuck::cast_slice(&low)).unwrap();
    gpu.one_shot(|cmd| {
        let mut ctx = FrameCtx::new(&gpu, cmd, None);
        r.state().passes().upsample.record(
            &mut ctx,
            r.state().uniforms(),
            &t.depth,
            t.depth_full.as_ref().unwrap(),
            0.05,
        );
        Ok(())
    })
    .unwrap();
    let full = read_f32(&gpu, t.depth_full.as_ref().unwrap()).unwrap();
    let mut interpolated = 0;
    for (i, d) in full.iter().enumerate() {
        let (x, y) = (i % w, i / w);
        if y < 7 {
            assert!(d.is_infinite(), "background pixel ({x},{y}) got fluid {d}");
            continue;
        }
        if y > 9 {
            assert!(d.is_finite(), "fluid pixel ({x},{y}) lost");
        }
        if d.is_finite() {
            let near = (2.0..=2.03).contains(d);
            assert!(near || *d == 3.0, "pixel ({x},{y}) has depth {d}, between the surfaces");
            // Bilinear samples fall between the low-resolution values 2 + 0.002·k.
            if near && ((d - 2.0) / 0.002 - ((d - 2.0) / 0.002).round()).abs() > 0.05 {
                interpolated += 1;
            }
        }
    }
    assert!(interpolated > 50, "inside the near surface the depth should be interpolated ({interpolated})");
    assert_clean(&gpu);
}

/// CPU reference of filter_narrow.comp (one dispatch).
#[allow(clippy::too_many_arguments)]
fn narrow_cpu(
    src: &[f32],
    w: usize,
    h: usize,
    f: f32,
    dir: (i32, i32),
    rho: f32,
    thr: f32,
    mu: f32,
    max_px: i32,
    r2d: i32,
    skip_bg: bool,
) -> Vec<f32> {
    let at = |x: i32, y: i32| {
        if x < 0 || y < 0 || x >= w as i32 || y >= h as i32 {
            f32::INFINITY
        } else {
            src[y as usize * w + x as usize]
        }
    };
    let mut out = src.to_vec();
    for y in 0..h as i32 {
        for x in 0..w as i32 {
            let d = at(x, y);
            if !(d < 1e30) {
                continue;
            }
            let rpx = (rho * f / d).clamp(1.0, max_px as f32);
            let sigma = (rpx * 0.5).max(0.5);
            let k = 1.0 / (2.0 * sigma * sigma);
            let (mut sum, mut ws) = (d, 1.0f32);
            let (mut lo, mut hi) = (d - thr, d + thr);
            let judge = |z: &mut f32, lo: &mut f32, hi: &mut f32| -> bool {
                if *z < *lo || (skip_bg && !(*z < 1e30)) {
                    return false;
                }
                if *z > *hi {
                    *z = d + mu;
                } else {
                    *lo = lo.min(*z - thr);
                    *hi = hi.max(*z + thr);
                }
                true
            };
            let mut pair = |i: i32, j: i32, dist2: f32, lo: &mut f32, hi: &mut f32| {
                let (mut za, mut zb) = if dir != (0, 0) {
                    (at(x - i, y - j), at(x + i, y + j))
                } else {
                    (at(x + i, y + j), at(x - i, y - j))
                };
                let ka = judge(&mut za, lo, hi);
                let kb = judge(&mut zb, lo, hi);
                if ka && kb {
                    let wt = (-dist2 * k).exp();
                    sum += wt * (za + zb);
                    ws += 2.0 * wt;
                }
            };
            if dir != (0, 0) {
                for i in 1..=rpx.ceil() as i32 {
                    pair(i * dir.0, i * dir.1, (i * i) as f32, &mut lo, &mut hi);
                }
            } else {
                let rr = r2d.min(rpx.ceil() as i32);
                for ring in 1..=rr {
                    for j in -ring..=ring {
                        for i in -ring..=ring {
                            if i.abs().max(j.abs()) != ring || j < 0 || (j == 0 && i < 0) {
                                continue;
                            }
                            pair(i, j, (i * i + j * j) as f32, &mut lo, &mut hi);
                        }
                    }
                }
            }
            out[y as usize * w + x as usize] = sum / ws;
        }
    }
    out
}

/// CPU reference of one curvature-flow iteration (curvature.glsl, untiled).
fn curvature_cpu(src: &[f32], w: usize, h: usize, f: f32, iter: i32, s: &meniscus::settings::Settings) -> Vec<f32> {
    let edge = s.filter.curvature.edge * s.radius;
    let at = |x: i32, y: i32, z: f32| {
        if x < 0 || y < 0 || x >= w as i32 || y >= h as i32 {
            return z;
        }
        let v = src[y as usize * w + x as usize];
        if v < 1e30 && (v - z).abs() < edge {
            v
        } else {
            z
        }
    };
    let mut out = src.to_vec();
    for y in 0..h as i32 {
        for x in 0..w as i32 {
            let z = src[y as usize * w + x as usize];
            let its =
                (s.filter.curvature.it_max as i32).min((f * s.filter.curvature.radius * s.radius / z.max(1e-6)) as i32);
            if !(z < 1e30) || iter >= its {
                continue;
            }
            let n = |dx: i32, dy: i32| at(x + dx, y + dy, z);
            let (zx, zy) = (0.5 * (n(1, 0) - n(-1, 0)), 0.5 * (n(0, 1) - n(0, -1)));
            let zxx = n(1, 0) - 2.0 * z + n(-1, 0);
            let zyy = n(0, 1) - 2.0 * z + n(0, -1);
            let zxy = 0.25 * (n(1, 1) - n(-1, 1) - n(1, -1) + n(-1, -1));
            let c = 1.0 / f;
            let zk = z + s.filter.curvature.kappa;
            let c2 = c * c;
            let dd = c2 * zx * zx + c2 * zy * zy + c2 * c2 * zk * zk;
            let dx = 2.0 * c2 * zx * zxx + 2.0 * c2 * zy * zxy + 2.0 * c2 * c2 * zk * zx;
            let dy = 2.0 * c2 * zx * zxy + 2.0 * c2 * zy * zyy + 2.0 * c2 * c2 * zk * zy;
            let hh = (c * (0.5 * zx * dx - zxx * dd) + c * (0.5 * zy * dy - zyy * dd)) / (2.0 * dd.powf(1.5));
            let stable = 0.2 * 2.0 * zk / f;
            let dt = if s.filter.curvature.dt > 0.0 { s.filter.curvature.dt.min(stable) } else { stable };
            out[y as usize * w + x as usize] = z - dt * hh;
        }
    }
    out
}

/// Narrow-range and curvature flow (1 and 4 iterations per dispatch) against their CPU references.
#[test]
fn narrow_range_and_curvature_flow_match_cpu_references() {
    let gpu = gpu();
    let (w, h) = (64usize, 48usize);
    let v = view([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], w as u32, h as u32, 40.0);
    let f = v.camera.focal_px(h as u32);
    let src = bumpy_depth(w, h);
    let run = |s: &meniscus::settings::Settings, its: u32| -> Vec<f32> { smooth_once(&gpu, &v, s, &src, its) };
    let close = |got: &[f32], want: &[f32], what: &str, tol: f32| {
        for i in 0..got.len() {
            if want[i].is_infinite() {
                assert!(got[i].is_infinite(), "{what}: pixel {i} background changed");
            } else {
                assert!((got[i] - want[i]).abs() < tol, "{what}: pixel {i}: gpu {} cpu {}", got[i], want[i]);
            }
        }
    };
    // Narrow range: two separable passes then one 2D pass.
    let mut s = settings(0.05);
    s.filter.method = Filter::NarrowRange;
    let (rho, thr, mu) =
        (s.filter.narrow.radius * s.radius, s.filter.narrow.threshold * s.radius, s.filter.narrow.mu * s.radius);
    let mp = s.filter.max_px as i32;
    for skip in [false, true] {
        s.filter.narrow.skip_background = skip;
        let a = narrow_cpu(&src, w, h, f, (1, 0), rho, thr, mu, mp, 0, skip);
        let b = narrow_cpu(&a, w, h, f, (0, 1), rho, thr, mu, mp, 0, skip);
        let want = narrow_cpu(&b, w, h, f, (0, 0), rho, thr, mu, mp, s.filter.narrow.px_2d as i32, skip);
        close(&run(&s, 0), &want, &format!("narrow-range, skip background {skip}"), 1e-4);
    }
    // Curvature flow: 8 iterations, CPU vs GPU untiled vs GPU tiled (4 per dispatch).
    let mut s = settings(0.05);
    s.filter.method = Filter::CurvatureFlow;
    s.filter.curvature.it_max = 8;
    s.filter.curvature.radius = 40.0;
    let mut want = src.clone();
    for it in 0..8 {
        want = curvature_cpu(&want, w, h, f, it, &s);
    }
    s.filter.curvature.iters_per_dispatch = 1;
    close(&run(&s, 8), &want, "curvature flow, 1 it/dispatch", 2e-4);
    s.filter.curvature.iters_per_dispatch = 4;
    close(&run(&s, 8), &want, "curvature flow, 4 it/dispatch", 2e-4);
    assert_clean(&gpu);
}

/// A procedural scene with the camera fitted to its `pct`…(1 − `pct`) percentile box, then moved to `closer` ×
/// its distance from the target.
fn splat_scene(
    name: &str,
    count: usize,
    w: u32,
    h: u32,
    pct: f64,
    closer: f32,
) -> (meniscus::scene::procedural::Generated, meniscus::view::View) {
    let g = meniscus::scene::procedural::generate(name, count).unwrap();
    let b = meniscus::scene::percentile_bounds(&g.particles.positions, pct).unwrap();
    let mut v = view([0.0, 0.0, 1.0], [0.0; 3], w, h, 45.0);
    v.camera = meniscus::scene::camera::Camera::fit(&b, w as f32 / h as f32);
    v.camera.eye = v.camera.target + (v.camera.eye - v.camera.target) * closer;
    (g, v)
}

/// The raw splat depth of `positions` with splat `mode` (no filter); None where the device lacks the mode.
fn splat_depth(
    gpu: &std::sync::Arc<meniscus::gpu::Gpu>,
    positions: &[[f32; 3]],
    radius: f32,
    v: &meniscus::view::View,
    mode: meniscus::named::SplatMode,
) -> Option<Vec<f32>> {
    let mut s = settings(radius);
    s.filter.method = Filter::None;
    s.splat.mode = mode;
    let mut r = Renderer::new(gpu).unwrap();
    if !r.state().supports_splat(mode) {
        return None;
    }
    *r.parts_mut().keep_raw_depth = true;
    r.upload(meniscus::renderer::Upload::points(positions)).unwrap();
    r.render(v, &s).unwrap();
    Some(read_f32(gpu, &r.state().targets().unwrap().depth).unwrap())
}

/// Two depth images agree pixel for pixel (equal, or within 1e-6).
fn assert_same_depth(got: &[f32], want: &[f32], what: &str) {
    for i in 0..got.len() {
        assert!(got[i] == want[i] || (got[i] - want[i]).abs() < 1e-6, "{what}: pixel {i}: {} vs {}", got[i], want[i]);
    }
}
/// Every rasterised splat variant produces exactly the compute splat's depth (same exact ray–sphere math).
#[test]
fn raster_splat_variants_equal_compute_splat() {
    use meniscus::named::SplatMode;
    let gpu = gpu();
    let (g, v) = splat_scene("drop", 3000, 96, 64, 0.01, 1.0);
    let mut depths = vec![];
    for &mode in SplatMode::ALL {
        match splat_depth(&gpu, &g.particles.positions, g.radius, &v, mode) {
            Some(d) => depths.push((mode, d)),
            None => eprintln!("{mode:?} unsupported on this device"),
        }
    }
    let (_, reference) = &depths[0];
    assert!(reference.iter().filter(|d| d.is_finite()).count() > 500);
    for (mode, d) in &depths[1..] {
        assert_same_depth(d, reference, &format!("{mode:?} vs compute"));
    }
    assert!(depths.len() >= 4, "lavapipe supports all variants");
    assert_clean(&gpu);
}

#[test]
fn skybox_faces_from_files() {
    let gpu = gpu();
    let dir = std::env::temp_dir().join(format!("meniscus-sky-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let colours = [[255u8, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 0], [0, 255, 255], [255, 0, 255]];
    for (name, c) in ["px", "nx", "py", "ny", "pz", "nz"].iter().zip(colours) {
        image::RgbaImage::from_pixel(4, 4, image::Rgba([c[0], c[1], c[2], 255]))
            .save(dir.join(format!("{name}.png")))
            .unwrap();
    }
    let (size, faces) = meniscus::scene::sky::load_faces(&dir).unwrap();
    assert_eq!(size, 4);
    let mut r = Renderer::new(&gpu).unwrap();
    r.set_background(meniscus::renderer::Backdrop::Sky { size, faces: &faces }).unwrap();
    let mut s = settings(0.05);
    s.background.sun_intensity = 0.0;
    s.filter.method = Filter::None;
    r.upload(meniscus::renderer::Upload::points(&[[100.0, 100.0, 100.0]])).unwrap();
    for (target, want) in [([1.0f32, 0.0, 0.0], [255u8, 0, 0]), ([0.0, 1.0, 0.001], [0, 0, 255])] {
        let mut v = view([0.0, 0.0, 0.0], target, 16, 16, 30.0);
        v.env.sky_cube = true;
        r.render(&v, &s).unwrap();
        let img = r.state().read_final().unwrap();
        let p = img.get_pixel(8, 8);
        for k in 0..3 {
            assert!((p[k] as i32 - want[k] as i32).abs() < 8, "looking at {target:?}: got {p:?}, want {want:?}");
        }
    }
    // A missing face is a clear error naming it.
    std::fs::remove_file(dir.join("nz.png")).unwrap();
    let e = meniscus::scene::sky::load_faces(&dir).unwrap_err().to_string();
    assert!(e.contains("nz.png"), "{e}");
    assert_clean(&gpu);
}

/// The `iso` pass against the CPU reference (src/field/iso/mod.rs) on a bumpy slab, a lone particle and a close
/// pair: same coverage and the same depth where both are covered.
#[test]
fn iso_surface_matches_cpu_ray_cast() {
    iso_matches_cpu(meniscus::settings::Kernel::Isotropic, (0.0, 1.0), 2.0, 8);
    // Bound spheres tighter than the surface: marches that start inside step back to the crossing. Every ray
    // still marching after one sample is queued for the second dispatch.
    iso_matches_cpu(meniscus::settings::Kernel::Isotropic, (0.0, 1.0), 1.3, 1);
}

/// The same with anisotropic kernels (Yu & Turk 2013): the `anisotropy` pass's kernels match the CPU
/// reference point by point (centre, det M, M), and the ray cast of their field matches the CPU cast.
#[test]
fn anisotropic_iso_surface_matches_cpu_ray_cast() {
    iso_matches_cpu(meniscus::settings::Kernel::Anisotropic, (0.0, 1.0), 2.0, 8);
    // Moved centres and stretched kernels: the grid's cells widen to reach them.
    iso_matches_cpu(meniscus::settings::Kernel::Anisotropic, (0.5, 1.5), 2.0, 2);
    // Yu & Turk's neighbourhood of 2 h: the kernels read rows of cells two away.
    iso_matches_cpu(meniscus::settings::Kernel::Anisotropic, (0.5, 2.0), 2.0, 8);
}

/// The iso weights (`iso_density`) and the anisotropic kernels (`anisotropy`) are computed once per set of
/// particles, not per frame, and again when the particles change: a renderer that drew one set and then gets
/// another draws the second exactly as a fresh renderer does.
#[test]
fn iso_weights_follow_the_particles() {
    weights_follow(meniscus::settings::Kernel::Isotropic, &["iso_density"]);
    weights_follow(meniscus::settings::Kernel::Anisotropic, &["iso_density", "anisotropy"]);
}

fn weights_follow(kernel: meniscus::settings::Kernel, once: &[&str]) {
    let gpu = gpu();
    let r = 0.05f32;
    let a = jittered_slab(7, [10, 3, 8], [-0.5, -0.3, -0.4], r, [1.0, 1.0, 1.0]);
    // Every third particle gone, but the ones that bound the set: other densities, so other weights, on the
    // same grid shape (so the renderer keeps its buffers and must know the weights changed).
    let (lo, hi) = a.iter().fold(([f32::MAX; 3], [f32::MIN; 3]), |(l, h), p| {
        (std::array::from_fn(|k| l[k].min(p[k])), std::array::from_fn(|k| h[k].max(p[k])))
    });
    let bounds = |p: &[f32; 3]| (0..3).any(|k| p[k] == lo[k] || p[k] == hi[k]);
    let b: Vec<[f32; 3]> = a.iter().enumerate().filter(|(i, p)| i % 3 != 0 || bounds(p)).map(|(_, p)| *p).collect();
    assert!(b.len() < a.len() * 3 / 4);
    let v = view([0.3, 1.2, 2.4], [0.0, 0.0, 0.0], 96, 72, 45.0);
    let mut s = settings(r);
    s.filter.method = Filter::None;
    s.surface = meniscus::settings::Surface::Iso;
    s.kernel = kernel;
    let ran = |t: &meniscus::timing::PassTimes, name: &str| t.0.iter().any(|(n, _)| n == name);
    let mut rd = Renderer::new(&gpu).unwrap();
    *rd.parts_mut().keep_raw_depth = true;
    rd.upload(meniscus::renderer::Upload::points(&a)).unwrap();
    let first = rd.render(&v, &s).unwrap();
    assert!(once.iter().all(|p| ran(&first, p)), "the first frame computes {once:?}: {:?}", first.0);
    let again = rd.render(&v, &s).unwrap();
    assert!(once.iter().all(|p| !ran(&again, p)) && ran(&again, "iso"), "a static frame reuses them: {:?}", again.0);
    rd.upload(meniscus::renderer::Upload::points(&b)).unwrap();
    let next = rd.render(&v, &s).unwrap();
    assert!(once.iter().all(|p| ran(&next, p)), "new particles: {once:?} again: {:?}", next.0);
    let got = read_f32(&gpu, &rd.state().targets().unwrap().depth).unwrap();
    let mut fresh = Renderer::new(&gpu).unwrap();
    *fresh.parts_mut().keep_raw_depth = true;
    fresh.upload(meniscus::renderer::Upload::points(&b)).unwrap();
    fresh.render(&v, &s).unwrap();
    let want = read_f32(&gpu, &fresh.state().targets().unwrap().depth).unwrap();
    let covered = want.iter().filter(|d| d.is_finite()).count();
    assert!(covered > 500, "covered {covered}");
    // The grid's within-cell order comes from atomics, so sums may round differently: 1e-4 r.
    let differ = got.iter().zip(&want).filter(|(g, w)| !(*g == *w || (*g - *w).abs() < 1e-4 * r)).count();
    assert_eq!(differ, 0, "{differ} pixels differ from a fresh renderer's");
    assert_clean(&gpu);
}

/// A slab of `n` = [x, y, z] particles at spacing 2 r from `origin`, each moved by up to ± `jitter`·r/2 per axis
/// (a seeded LCG, x outermost, then z, then y: the order the tests' numbers were measured with).
fn jittered_slab(seed: u32, n: [usize; 3], origin: [f32; 3], r: f32, jitter: [f32; 3]) -> Vec<[f32; 3]> {
    let mut seed = seed;
    let mut rnd = || {
        seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
        (seed >> 8) as f32 / (1u32 << 24) as f32 - 0.5
    };
    let mut pts = vec![];
    for i in 0..n[0] {
        for k in 0..n[2] {
            for j in 0..n[1] {
                let p = [i, j, k].map(|c| c as f32 * 2.0 * r);
                pts.push(std::array::from_fn(|a| origin[a] + p[a] + rnd() * r * jitter[a]));
            }
        }
    }
    pts
}

/// `shape`: the anisotropic kernels' centre blend and, up to 1.5, their stretch; above it, stretch 1 and a
/// neighbourhood of that many supports. `first_steps`: samples of the cast's first dispatch before a ray is
/// queued for the second; the depth must equal, bit for bit, the one-dispatch cast's (first_steps 0).
fn iso_matches_cpu(kernel: meniscus::settings::Kernel, (blend, shape): (f32, f32), bound: f32, first_steps: u32) {
    use meniscus::field::iso::{cast_with, ray_end, Aniso, IsoGrid};
    let gpu = gpu();
    let (w, h) = (128usize, 96usize);
    let r = 0.05f32;
    let mut pts = jittered_slab(12345, [14, 3, 10], [-0.65, -0.3, -0.5], r, [1.0, 1.5, 1.0]);
    pts.push([0.0, 0.45, 0.0]); // lone particle: a sphere of ≈ 1.24 r
    pts.push([0.4, 0.35, 0.1]); // a pair that merges
    pts.push([0.4 + 2.2 * r, 0.35, 0.1]);
    let v = view([0.3, 1.2, 2.4], [0.0, 0.0, 0.0], w as u32, h as u32, 45.0);
    let mut s = settings(r);
    s.filter.method = Filter::None;
    s.surface = meniscus::settings::Surface::Iso;
    s.kernel = kernel;
    // The slab's points have about 12–30 neighbours within 4 r: most get flat kernels, the lone one a sphere.
    s.anisotropy.min_neighbours = 12;
    s.anisotropy.centre_blend = blend;
    if shape <= 1.5 {
        s.anisotropy.stretch = shape;
    } else {
        s.anisotropy.radius = shape;
    }
    s.iso.bound = bound;
    // Every pixel marches (particles are ≈ 2 px here anyway); coarse-to-fine has its own test.
    s.iso.fine_px = 0.0;
    let mut rd = Renderer::new(&gpu).unwrap();
    *rd.parts_mut().keep_raw_depth = true;
    rd.upload(meniscus::renderer::Upload::points(&pts)).unwrap();
    s.iso.first_steps = 0;
    render_counted(&mut rd, &v, &s).unwrap();
    let one_dispatch = read_f32(&gpu, &rd.state().targets().unwrap().depth).unwrap();
    let work = |rd: &Renderer| {
        rd.state()
            .surfaces()
            .technique::<meniscus::surface::iso::IsoSurface>()
            .unwrap()
            .queue()
            .unwrap()
            .work(&gpu)
            .unwrap()
    };
    let whole = work(&rd);
    s.iso.first_steps = first_steps;
    s.iso.rest_lanes = 1;
    render_counted(&mut rd, &v, &s).unwrap();
    let got = read_f32(&gpu, &rd.state().targets().unwrap().depth).unwrap();
    let differ = got.iter().zip(&one_dispatch).filter(|(a, b)| a.to_bits() != b.to_bits()).count();
    assert_eq!(differ, 0, "first_steps {first_steps}: {differ} pixels differ from the one-dispatch cast");
    // The pass's count of its field samples: the same samples whether a ray is marched in one dispatch or
    // continued by the second (one lane per ray), at least one per pixel that hit.
    let split = work(&rd);
    let hits = got.iter().filter(|d| d.is_finite()).count() as u64;
    assert_eq!(whole.queued, 0, "one dispatch queues nothing");
    assert!(split.queued > 0 && whole.samples >= hits && hits > 1000, "{whole:?} {split:?}, {hits} hits");
    eprintln!("iso: one dispatch {whole:?}, split {split:?}, {hits} hits");
    assert_eq!(split.samples, whole.samples, "first_steps {first_steps}: the samples of the split cast");
    // The first dispatch ran on the tiles of the bound spheres' depth that hold fluid (iso_tiles.comp): every tile
    // with a hit among them, the same tiles either way, and not the whole screen (the slab covers part of it).
    let t = meniscus::shader_constants::LOCAL_2D as usize;
    let mut hit_tiles = std::collections::HashSet::new();
    for (k, d) in got.iter().enumerate() {
        if d.is_finite() {
            hit_tiles.insert((k % w / t, k / w / t));
        }
    }
    let screen = (w.div_ceil(t) * h.div_ceil(t)) as u64;
    assert_eq!(split.tiles, whole.tiles, "the tiles cast");
    assert!(
        split.tiles >= hit_tiles.len() as u64 && split.tiles < screen,
        "{} tiles cast, {} hold a hit, {screen} on the screen",
        split.tiles,
        hit_tiles.len()
    );
    // The queued rays marched by 8 and by 32 lanes each (isotropic kernels, where the device's subgroups allow):
    // the same rays bracketed on a finer lattice, so only queued pixels may differ, each within the
    // interpolation's error or by a crossing thinner than one lane's step; the CPU comparison below holds for all.
    let mut casts = vec![(got, "one lane per queued ray".to_string())];
    for lanes in [8, 32] {
        if kernel != meniscus::settings::Kernel::Isotropic || gpu.info.shuffle_lanes(lanes) != lanes {
            continue;
        }
        s.iso.rest_lanes = lanes;
        rd.render(&v, &s).unwrap();
        let queue = rd.state().surfaces().technique::<meniscus::surface::iso::IsoSurface>().unwrap().queue().unwrap();
        let queued = queue.work(&gpu).unwrap().queued as usize;
        let wide_got = read_f32(&gpu, &rd.state().targets().unwrap().depth).unwrap();
        let (mut differ, mut far) = (0, 0);
        for (a, b) in wide_got.iter().zip(&one_dispatch) {
            if a.to_bits() != b.to_bits() {
                differ += 1;
                if !(a.is_finite() && b.is_finite() && (a - b).abs() < 0.05 * r) {
                    far += 1;
                }
            }
        }
        eprintln!(
            "rest_lanes {lanes}: {queued} rays queued, {differ} pixels differ from one lane's march, {far} by ≥ 0.05 r"
        );
        assert!(queued > 0, "no ray was queued: the wide dispatch did not run");
        assert!(differ <= queued, "{differ} pixels differ but {queued} rays were queued");
        assert!(far * 100 <= queued, "{far} of {queued} queued pixels differ by 0.05 r or in coverage");
        casts.push((wide_got, format!("{lanes} lanes per queued ray")));
    }

    let grid = IsoGrid::build_reaching(&pts, s.iso.support * r, s.iso_reach());
    let inv = grid.inv_density();
    let p = meniscus::field::iso::IsoParams { near: v.camera.near, ..s.iso_params() };
    let aniso = p.aniso.map(|a| grid.anisotropy(&a));
    if let Some(want) = &aniso {
        // The GPU grid sorts within a cell in the atomics' order: match the points by position.
        let b = rd.state().surfaces().technique::<meniscus::surface::iso::IsoSurface>().and_then(|i| i.grid()).unwrap();
        let n = b.shape.dims[3] as usize;
        let points: Vec<[f32; 4]> =
            bytemuck::cast_slice(&meniscus::gpu::transfer::read_buffer(&gpu, &b.points, n as u64 * 16).unwrap())
                .to_vec();
        let got: Vec<Aniso> =
            bytemuck::cast_slice(&meniscus::gpu::transfer::read_buffer(&gpu, &b.aniso, n as u64 * 48).unwrap())
                .to_vec();
        let index: std::collections::HashMap<[u32; 3], usize> =
            grid.points.iter().enumerate().map(|(i, q)| ([q[0], q[1], q[2]].map(f32::to_bits), i)).collect();
        assert_eq!(n, grid.points.len());
        let (mut flat, mut round) = (0, 0);
        for (q, g) in points.iter().zip(&got) {
            let w = &want[index[&[q[0], q[1], q[2]].map(f32::to_bits)]];
            assert!((g.centre() - w.centre()).length() < 1e-5 * r, "centre {:?} vs {:?}", g.centre(), w.centre());
            assert!((g.det() - w.det()).abs() < 1e-3 * w.det(), "det M {} vs {}", g.det(), w.det());
            let e = (g.matrix() - w.matrix()).to_cols_array().iter().fold(0f32, |m, x| m.max(x.abs()));
            assert!(e < 2e-3 * w.det(), "M differs by {e}: {:?} vs {:?}", g.matrix(), w.matrix());
            let (axes, _) = w.axes();
            if axes[0] > 1.5 * axes[2] {
                flat += 1;
            } else if w.matrix() == glam::Mat3::IDENTITY {
                round += 1;
            }
        }
        assert!(flat > n / 2 && round >= 1, "{flat} flat and {round} round kernels of {n}");
    }
    let cast = |eye, dir, start, end| cast_with(&grid, &inv, aniso.as_deref(), &p, eye, dir, start, end);
    for (got, lanes) in &casts {
        let label = format!("{kernel:?}, bound {bound} r, {lanes}");
        check_cast(got, &pts, &v, &s, (w, h), |eye, dir| ray_end(&grid, eye, dir), cast, &label, (0.01, 0.99));
    }
    assert_clean(&gpu);
}

/// The GPU cast `got` (w × h) of `pts` against a CPU cast per pixel: `cast(eye, dir, start, end)` from the bound
/// spheres' depth to the far bound (per pixel, or per 8×8 tile when the splat culls) or `box_end(eye, dir)`.
/// Same coverage on all but 0.5 % of the pixels, at least `frac` of them within `tol`·r, none past ½ r.
#[allow(clippy::too_many_arguments)]
fn check_cast(
    got: &[f32],
    pts: &[[f32; 3]],
    v: &meniscus::view::View,
    s: &meniscus::settings::Settings,
    (w, h): (usize, usize),
    box_end: impl Fn(glam::Vec3, glam::Vec3) -> f32,
    cast: impl Fn(glam::Vec3, glam::Vec3, f32, f32) -> Option<f32>,
    label: &str,
    (tol, frac): (f32, f32),
) {
    use glam::Vec3;
    let (r, bound) = (s.radius, s.iso.bound);
    let view_m = v.camera.view();
    let inv_view = view_m.inverse();
    let f = v.camera.focal_px(h as u32) as f64;
    let centres: Vec<[f64; 3]> =
        pts.iter().map(|q| view_m.transform_point3(Vec3::from(*q)).as_dvec3().to_array()).collect();
    // The march stops at the far bound: per pixel, or per 8×8 tile when the splat culls (splat_cull.comp).
    let tile = meniscus::shader_constants::SPLAT_TILE as usize;
    let c32: Vec<[f32; 3]> = centres.iter().map(|c| c.map(|x| x as f32)).collect();
    let per_tile =
        meniscus::passes::splat::cull_pays(f as f32 * bound * r / (v.camera.eye - glam::Vec3::ZERO).length());
    let backs = tile_back(&c32, bound * r, w, h, f as f32, v.camera.near, tile);
    let (mut both, mut mismatch, mut close, mut max_err) = (0, 0, 0, 0f32);
    for y in 0..h {
        for x in 0..w {
            let dv = pixel_dir(x, y, w, h, f);
            let hits: Vec<(f64, f64)> = centres.iter().filter_map(|c| ray_sphere(dv, *c, (bound * r) as f64)).collect();
            let start = hits.iter().map(|h| h.0).fold(f64::INFINITY, f64::min);
            let back = if per_tile {
                backs[(y / tile) * w.div_ceil(tile) + x / tile]
            } else {
                hits.iter().map(|h| h.1).fold(0.0, f64::max) as f32
            };
            let dir = inv_view.transform_vector3(Vec3::new(dv[0] as f32, dv[1] as f32, dv[2] as f32));
            let eye = v.camera.eye;
            let want = if start.is_finite() { cast(eye, dir, start as f32, box_end(eye, dir).min(back)) } else { None };
            let g = got[y * w + x];
            match want {
                Some(d) if g.is_finite() => {
                    both += 1;
                    let e = (g - d).abs();
                    max_err = max_err.max(e);
                    if e < tol * r {
                        close += 1;
                    }
                }
                None if g.is_infinite() => {}
                _ => mismatch += 1,
            }
        }
    }
    eprintln!("{label}, far bound per tile {per_tile}: {both} pixels, {mismatch} differ in coverage, {close} within {tol} r, max {max_err}");
    assert!(both > 1500, "covered {both}");
    assert!(mismatch * 200 <= both, "coverage differs on {mismatch} of {both} pixels");
    assert!(close as f32 >= both as f32 * frac, "{close} of {both} pixels within {tol} r");
    assert!(max_err < 0.5 * r, "max depth difference {max_err}");
}

/// The smoothed field's sparse lattice read back densely: (allocated bricks, sums, field) over the whole box.
fn read_lattice(
    gpu: &std::sync::Arc<meniscus::gpu::Gpu>,
    vol: &meniscus::surface::iso::volume::IsoVolume,
) -> (Vec<bool>, Vec<[u32; 2]>, Vec<[f32; 2]>) {
    let shape = vol.shape;
    let read = |buf, bytes: usize| meniscus::gpu::transfer::read_buffer(gpu, buf, bytes as u64).unwrap();
    let table: Vec<u32> = bytemuck::pod_collect_to_vec(&read(&vol.table, 4 * shape.table_len()));
    let header: Vec<u32> = bytemuck::pod_collect_to_vec(&read(&vol.header, 16));
    let bricks = header[3] as usize;
    assert!(bricks <= vol.capacity as usize, "{bricks} bricks over the pool's {}", vol.capacity);
    let bv = meniscus::field::volume::STORED_BRICK_VOXELS as usize;
    let acc: Vec<[u32; 2]> = bytemuck::pod_collect_to_vec(&read(&vol.acc, 8 * bv * bricks.max(1)));
    let (mut dacc, mut dfield) = (vec![[0u32; 2]; shape.voxels()], vec![[0f32; 2]; shape.voxels()]);
    let field = meniscus::field::volume::VolumeShape::field(&acc);
    let nb = shape.bricks;
    for (b, &e) in table.iter().enumerate() {
        if e == 0 {
            continue;
        }
        let (bx, by, bz) = (b as u32 % nb[0], (b as u32 / nb[0]) % nb[1], b as u32 / (nb[0] * nb[1]));
        // Each brick's own voxels (storage coordinates 1 … 8; its apron holds its neighbours').
        for l in 0..512u32 {
            let (lx, ly, lz) = (l & 7, (l >> 3) & 7, l >> 6);
            let v = shape.index(bx * 8 + lx, by * 8 + ly, bz * 8 + lz);
            let k = (e as usize - 1) * bv + (lx + 1 + 10 * (ly + 1 + 10 * (lz + 1))) as usize;
            dacc[v] = acc[k];
            dfield[v] = field[k];
        }
    }
    (table.iter().map(|&e| e != 0).collect(), dacc, dfield)
}

/// The smoothed iso field (`[iso] smoothing`): the sparse lattice that `iso_volume` builds equals the CPU
/// reference's dense one (VolumeShape::{marked, deposit}) voxel by voxel, with exactly
/// the bricks the reference marks allocated; the bulk of a thick slab is blurred while a lone droplet keeps
/// its exact field; the cast matches the CPU march over the CPU field (smoothed_field); and a second frame of
/// the same particles does not build it again.
#[test]
fn smoothed_iso_field_matches_cpu() {
    use meniscus::field::iso::{march, ray_end, IsoGrid};
    use meniscus::field::volume::{bulk_weight, smoothed_field};
    let gpu = gpu();
    let (w, h) = (128usize, 96usize);
    let r = 0.05f32;
    let mut pts = jittered_slab(12345, [14, 5, 10], [-0.65, -0.3, -0.5], r, [1.0, 1.5, 1.0]);
    // A block on an exact lattice in front of the disordered slab: its particles deposit the wider blur.
    pts.extend(jittered_slab(1, [6, 3, 4], [0.2, -0.3, 0.55], r, [0.0; 3]));
    let lone = [0.0, 0.55, 0.0];
    pts.push(lone);
    let v = view([0.3, 1.2, 2.4], [0.0, 0.0, 0.0], w as u32, h as u32, 45.0);
    let mut s = settings(r);
    s.filter.method = Filter::None;
    s.surface = meniscus::settings::Surface::Iso;
    s.iso.smoothing = meniscus::surface::iso::params::Params::default().smoothing;
    let mut rd = Renderer::new(&gpu).unwrap();
    *rd.parts_mut().keep_raw_depth = true;
    rd.upload(meniscus::renderer::Upload::points(&pts)).unwrap();
    let first = rd.render(&v, &s).unwrap();
    let again = rd.render(&v, &s).unwrap();
    let ran = |t: &meniscus::timing::PassTimes, name: &str| t.0.iter().any(|(n, _)| n == name);
    assert!(ran(&first, "iso_volume"), "{:?}", first.0);
    assert!(!ran(&again, "iso_volume"), "a static frame reuses it: {:?}", again.0);
    let got = read_f32(&gpu, &rd.state().targets().unwrap().depth).unwrap();
    let iso = rd.state().surfaces().technique::<meniscus::surface::iso::IsoSurface>().unwrap();
    let (b, vol) = (iso.grid().unwrap(), iso.volume().expect("the lattice"));
    let shape = vol.shape;
    assert_eq!(shape.spacing, s.iso.voxel * r, "the voxel size asked for");
    let (alloc, acc_gpu, field_gpu) = read_lattice(&gpu, vol);

    let grid = IsoGrid::build(&pts, s.iso.support * r);
    // The casts' copy of the cell table: the same cells, each with its empty distance (iso_empty.comp) in the
    // count's top bits, as the CPU grid computes it; above the slab, around the droplet, cells of distance 2 (the
    // casts skip by it there).
    assert_eq!(b.shape.dims[..3], grid.dims, "the GPU grid has the CPU grid's shape");
    let words: Vec<u32> = bytemuck::pod_collect_to_vec(
        &meniscus::gpu::transfer::read_buffer(&gpu, &b.cells_empty, 8 * grid.cells.len() as u64).unwrap(),
    );
    let bits = 32 - meniscus::shader_constants::ISO_EMPTY_BITS;
    for (k, (cell, &e)) in grid.cells.iter().zip(grid.empty()).enumerate() {
        let got = [words[2 * k], words[2 * k + 1] & ((1 << bits) - 1), words[2 * k + 1] >> bits];
        assert_eq!(got, [cell[0], cell[1], e as u32], "cell {k}");
    }
    assert!((0..=2).all(|e| grid.empty().contains(&e)), "empty distances {:?}", grid.empty());
    let inv = grid.inv_density();
    let c = grid.volume_weights(2.0 * r);
    // iso_density's (c_j, o_j) against the reference's, as sorted lists (the GPU orders a cell's points its own
    // way); both kinds of particle are there: the lattice block's (order 1) and the slab's and the droplet's (0).
    let counts: Vec<[f32; 2]> = bytemuck::pod_collect_to_vec(
        &meniscus::gpu::transfer::read_buffer(&gpu, &b.counts, 8 * grid.points.len() as u64).unwrap(),
    );
    for k in 0..2 {
        let sorted = |v: &[[f32; 2]]| {
            let mut x: Vec<f32> = v.iter().map(|w| w[k]).collect();
            x.sort_by(f32::total_cmp);
            x
        };
        let worst = sorted(&counts).iter().zip(sorted(&c)).map(|(a, b)| (a - b).abs()).fold(0f32, f32::max);
        assert!(worst < 1e-3, "iso_density's {} differ from the reference's by up to {worst}", ["c_j", "o_j"][k]);
    }
    let ordered = c.iter().filter(|w| w[1] > 0.99).count();
    let liquid = c.iter().filter(|w| w[1] < 0.01).count();
    assert!(ordered >= 40 && liquid >= 400, "{ordered} particles on a lattice, {liquid} not");
    let p = meniscus::field::iso::IsoParams { near: v.camera.near, ..s.iso_params() };
    let vp = p.volume.expect("smoothing on");
    let weighted: Vec<[f32; 4]> = grid.points.iter().zip(&inv).map(|(q, &i)| [q[0], q[1], q[2], i]).collect();
    let marked = shape.marked(&grid.points, |q| glam::Vec3::new(q[0], q[1], q[2]));
    assert_eq!(alloc, marked, "the allocated bricks are the ones the reference marks");
    let used = marked.iter().filter(|&&m| m).count();
    assert!(used < marked.len(), "{used} of {} bricks: the lattice is sparse", marked.len());
    let acc = shape.deposit(&weighted, &c, &vp);
    // The deposit's own count of its work: the reference's point–voxel pairs (a pair at the kernel's rim may
    // round the other way on another device's arithmetic: within 0.01 %).
    let work = vol.work(&gpu).unwrap();
    let pairs = shape.deposits(&weighted, &c, &vp);
    eprintln!("iso_volume: {work:?}; the reference's {pairs} point–voxel pairs");
    assert!(pairs > 10_000 && work.deposits.abs_diff(pairs) <= pairs / 10_000, "{work:?} against {pairs} pairs");
    assert_eq!(work.atomics, if gpu.info.int64_atomics { work.deposits } else { 2 * work.deposits });
    let field = meniscus::field::volume::VolumeShape::field(&acc);
    // Per-term rounding to fixed point may differ by a unit where the weights' last bit does.
    let worst = acc.iter().zip(&acc_gpu).map(|(a, g)| a[0].abs_diff(g[0]).max(a[1].abs_diff(g[1]))).max().unwrap();
    assert!(worst <= 64, "fixed-point sums differ by up to {worst} units");
    let err = field
        .iter()
        .zip(&field_gpu)
        .map(|(a, g)| (a[0] - g[0]).abs().max((a[1] - g[1]).abs() / 16.0))
        .fold(0f32, f32::max);
    assert!(err < 1e-4, "smoothed field differs by up to {err}");
    // Both kinds of water are there: voxels fully blurred (bulk) and voxels left to the exact field (the
    // droplet's, whose blurred mass stays low).
    let (mut bulk, mut raw) = (0, 0);
    for f in &field {
        if f[0] > 0.05 {
            match bulk_weight(f[1] / f[0], vp.bulk) {
                x if x >= 1.0 => bulk += 1,
                x if x <= 0.0 => raw += 1,
                _ => {}
            }
        }
    }
    assert!(bulk > 100 && raw > 0, "{bulk} blurred and {raw} raw voxels inside the water");
    // The lone droplet keeps its exact field: the sphere of φ = 0.6 (radius ≈ 1.24 r), not a blurred-away blob.
    let at = smoothed_field(&grid, &inv, &shape, (&field, &marked), &p, glam::Vec3::from(lone)).0;
    assert!(at > 0.6, "the droplet's centre: field {at}");

    let cast = |eye, dir, start, end| {
        march(|x| smoothed_field(&grid, &inv, &shape, (&field, &marked), &p, x), &p, eye, dir, start, end)
    };
    check_cast(&got, &pts, &v, &s, (w, h), |eye, dir| ray_end(&grid, eye, dir), cast, "smoothed", (0.01, 0.99));
    assert_clean(&gpu);
}

/// The smoothed field follows the water, not its box: two slabs 41 m apart at r = 5 cm (a box of 17 M voxels
/// at the voxel size, past the 16 M the dense lattice capped and coarsened at) keep the voxel size asked for,
/// allocate only the bricks the reference marks, and both are drawn.
#[test]
fn smoothed_iso_field_is_sparse_in_a_large_box() {
    let gpu = gpu();
    let r = 0.05f32;
    let mut pts = jittered_slab(7, [10, 4, 10], [-0.5, 0.0, -0.5], r, [1.0, 1.0, 1.0]);
    pts.extend(jittered_slab(8, [10, 4, 10], [23.5, 24.0, 23.5], r, [1.0, 1.0, 1.0]));
    let mut s = settings(r);
    s.filter.method = Filter::None;
    s.surface = meniscus::settings::Surface::Iso;
    s.iso.smoothing = meniscus::surface::iso::params::Params::default().smoothing;
    let mut rd = Renderer::new(&gpu).unwrap();
    rd.upload(meniscus::renderer::Upload::points(&pts)).unwrap();
    let v = view([50.0, 50.0, 50.0], [12.0, 12.0, 12.0], 160, 120, 50.0);
    rd.render(&v, &s).unwrap();
    let iso = rd.state().surfaces().technique::<meniscus::surface::iso::IsoSurface>().unwrap();
    let vol = iso.volume().expect("the lattice");
    let shape = vol.shape;
    assert_eq!(shape.spacing, s.iso.voxel * r, "the voxel size asked for, not a coarser one");
    assert!(shape.voxels() > 16 << 20, "the box holds {} voxels", shape.voxels());
    let (alloc, _, field) = read_lattice(&gpu, vol);
    let used = alloc.iter().filter(|&&a| a).count();
    let marked = shape.marked(&pts, |&q| glam::Vec3::from(q)).iter().filter(|&&m| m).count();
    assert_eq!(used, marked);
    // Memory follows the occupied bricks: the pool holds them with at most a quarter to spare.
    assert!((vol.capacity as usize) <= used + used / 4 + 1, "pool {} for {used} bricks", vol.capacity);
    assert!(used * 512 * 100 < shape.voxels(), "{used} bricks of {} voxels", shape.voxels());
    // Water in both slabs: the field reaches its bulk value around each.
    for centre in [[0.0f32, 0.15, 0.0], [24.0, 24.15, 24.0]] {
        let f = shape.sample(&field, glam::Vec3::from(centre))[0];
        assert!(f > 0.6, "field {f} inside the slab at {centre:?}");
    }
    assert_clean(&gpu);
}

/// The deposit's two paths give the same sums: one 64-bit atomic per voxel (devices with
/// shaderBufferInt64Atomics, lavapipe among them) and two 32-bit atomics (`no_int64_atomics`, as on devices
/// without them) write the same words at every voxel of the same lattice (integer sums, in any order).
#[test]
fn the_64_bit_deposit_equals_the_32_bit_one() {
    let r = 0.05f32;
    let pts = jittered_slab(99, [12, 6, 9], [-0.6, -0.2, -0.45], r, [1.0, 1.2, 1.0]);
    let mut s = settings(r);
    s.filter.method = Filter::None;
    s.surface = meniscus::settings::Surface::Iso;
    s.iso.smoothing = meniscus::surface::iso::params::Params::default().smoothing;
    let v = view([0.3, 1.2, 2.4], [0.0, 0.0, 0.0], 96, 64, 45.0);
    let lattice = |no_int64_atomics: bool| {
        let gpu = meniscus::gpu::Gpu::new(&meniscus::gpu::GpuOptions {
            validation: true,
            no_int64_atomics,
            ..Default::default()
        })
        .unwrap();
        let mut rd = Renderer::new(&gpu).unwrap();
        rd.upload(meniscus::renderer::Upload::points(&pts)).unwrap();
        rd.render(&v, &s).unwrap();
        let state = rd.state();
        let vol = state.surfaces().technique::<meniscus::surface::iso::IsoSurface>().and_then(|i| i.volume());
        let vol = vol.expect("the lattice");
        let out = read_lattice(&gpu, vol);
        let work = vol.work(&gpu).unwrap();
        assert_clean(&gpu);
        (gpu.info.int64_atomics, gpu.info.name.clone(), out, work)
    };
    let (wide, name, (alloc64, acc64, _), work64) = lattice(false);
    let (narrow, _, (alloc32, acc32, _), work32) = lattice(true);
    // The same deposits either way; one atomic each, or two.
    assert_eq!(work64.deposits, work32.deposits);
    assert_eq!(work32.atomics, 2 * work32.deposits);
    assert_eq!(work64.atomics, if wide { work64.deposits } else { 2 * work64.deposits });
    if name.contains("llvmpipe") {
        assert!(wide, "lavapipe has shaderBufferInt64Atomics: the 64-bit path must run here");
    }
    eprintln!("{name}: 64-bit buffer atomics {wide}");
    assert!(!narrow, "no_int64_atomics leaves them off");
    assert_eq!(alloc64, alloc32, "the same bricks");
    assert!(acc64.iter().filter(|a| a[0] > 0).count() > 1000, "the slab deposited its sums");
    let differ = acc64.iter().zip(&acc32).filter(|(a, b)| a != b).count();
    assert_eq!(differ, 0, "{differ} voxels differ between the 64-bit and the 32-bit deposit");
}

/// No creases at voxel faces: a flat, tilted sheet of water (a lattice of particles rotated against the voxel
/// axes, the field blurred everywhere so the surface is the lattice's alone) rendered from above has normals
/// that vary smoothly. Measured: the largest angle between horizontally or vertically adjacent pixels'
/// normals on the sheet's top, away from its edges: 0.21° with the quadratic B-spline read; with trilinear
/// reads of the same lattice 1.32° (the normals jump where the surface crosses a voxel face: the streaks the
/// wave scene showed).
#[test]
fn smoothed_iso_surface_has_no_seams_at_voxel_faces() {
    let gpu = gpu();
    let r = 0.05f32;
    let (rot, tilt) = (glam::Quat::from_rotation_y(0.37), glam::Quat::from_rotation_x(0.21));
    let mut pts = vec![];
    for i in 0..30 {
        for j in 0..4 {
            for k in 0..30 {
                let p = glam::Vec3::new(i as f32 - 14.5, j as f32 - 4.0, k as f32 - 14.5) * 2.0 * r;
                pts.push((tilt * rot * p).to_array());
            }
        }
    }
    let mut s = settings(r);
    s.filter.method = Filter::None;
    s.surface = meniscus::settings::Surface::Iso;
    s.iso.smoothing = meniscus::surface::iso::params::Params::default().smoothing;
    s.iso.bulk = [0.0, 0.0];
    // The march's depth to well below a pixel's normal step (its last linear interpolation alone leaves an
    // error that follows where each ray starts: the bound spheres' pattern).
    s.iso.refine = 8;
    let mut rd = Renderer::new(&gpu).unwrap();
    rd.upload(meniscus::renderer::Upload::points(&pts)).unwrap();
    let (w, h) = (160usize, 120usize);
    let v = view([0.0, 2.0, 0.6], [0.0, 0.0, 0.0], w as u32, h as u32, 30.0);
    rd.render(&v, &s).unwrap();
    let t = rd.state().targets().unwrap();
    let words: Vec<u32> = bytemuck::pod_collect_to_vec(&read_image(&gpu, &t.normals).unwrap());
    let depth = read_f32(&gpu, &t.depth).unwrap();
    let n: Vec<glam::Vec3> = words.iter().map(|&x| glam::Vec3::from(meniscus::passes::normals::unpack(x))).collect();
    let inside = |x: usize, y: usize| {
        (x >= 3 && y >= 3 && x + 3 < w && y + 3 < h)
            && (0..7).all(|d| depth[(y + d - 3) * w + x].is_finite() && depth[y * w + x + d - 3].is_finite())
    };
    let (mut worst, mut count) = (0f32, 0);
    for y in 0..h - 1 {
        for x in 0..w - 1 {
            if !(inside(x, y) && inside(x + 1, y) && inside(x, y + 1)) {
                continue;
            }
            let a = n[y * w + x];
            for b in [n[y * w + x + 1], n[(y + 1) * w + x]] {
                worst = worst.max(a.angle_between(b).to_degrees());
            }
            count += 1;
        }
    }
    eprintln!("seams: {count} pixel pairs on the sheet, largest normal step {worst:.3}°");
    assert!(count > 5000, "{count} pixels on the sheet");
    assert!(worst < 0.5, "normals step by {worst}° between adjacent pixels");
    assert_clean(&gpu);
}

/// Coarse-to-fine (`[iso] fine_px`): where particles are large on screen only every second pixel of every
/// second row marches; the others take their marched neighbours' mean depth, with one Newton step of the field
/// where the surface curves, and march where the neighbours disagree. The surface must be the march's: against
/// the march refined by 6 bisections (the accurate surface; the CPU test above checks the march), the same
/// coverage and 95 % of the pixels within 0.005 r (the march itself: 69 %; the fallbacks, marched where
/// neighbours disagree, keep the march's accuracy).
#[test]
fn iso_coarse_to_fine_matches_the_march() {
    let gpu = gpu();
    let r = 0.05f32;
    let mut pts = jittered_slab(12345, [14, 3, 10], [-0.65, -0.3, -0.5], r, [1.0, 1.5, 1.0]);
    pts.push([0.0, 0.45, 0.0]); // lone particle: a sphere of ≈ 1.24 r
    pts.push([0.4, 0.35, 0.1]); // a pair that merges
    pts.push([0.4 + 2.2 * r, 0.35, 0.1]);
    // F = 144 / (2 tan 22.5°) ≈ 174 px: at 1.0–1.8 from the eye a particle is 5–9 px in radius.
    let v = view([0.2, 0.8, 1.1], [0.0, 0.0, 0.0], 192, 144, 45.0);
    let mut s = settings(r);
    s.filter.method = Filter::None;
    s.surface = meniscus::settings::Surface::Iso;
    let mut rd = Renderer::new(&gpu).unwrap();
    *rd.parts_mut().keep_raw_depth = true;
    rd.upload(meniscus::renderer::Upload::points(&pts)).unwrap();
    let mut depth = |fine_px: f32, refine: u32| {
        s.iso.fine_px = fine_px;
        s.iso.refine = refine;
        rd.render(&v, &s).unwrap();
        read_f32(&gpu, &rd.state().targets().unwrap().depth).unwrap()
    };
    let exact = depth(0.0, 6);
    let march = depth(0.0, 0);
    let fine = depth(4.0, 0);
    let within = |got: &[f32], tol: f32| {
        let (mut both, mut mismatch, mut close) = (0, 0, 0);
        for (g, e) in got.iter().zip(&exact) {
            match (g.is_finite(), e.is_finite()) {
                (true, true) => {
                    both += 1;
                    close += ((g - e).abs() < tol) as usize;
                }
                (false, false) => {}
                _ => mismatch += 1,
            }
        }
        (both, mismatch, close)
    };
    let (both, mismatch, close) = within(&fine, 0.005 * r);
    let (_, _, march_close) = within(&march, 0.005 * r);
    let changed = fine.iter().zip(&march).filter(|(f, m)| f.is_finite() && f.to_bits() != m.to_bits()).count();
    eprintln!("coarse-to-fine: {both} pixels, {mismatch} differ in coverage, {close} within 0.005 r (the march: {march_close}), {changed} changed from the march (fine pixels and polished marched ones)");
    assert!(both > 10_000, "covered {both}");
    assert!(changed * 2 > both, "coarse-to-fine changed only {changed} of {both} pixels");
    assert!(mismatch * 200 <= both, "coverage differs on {mismatch} of {both} pixels");
    assert!(
        close * 100 >= both * 95 && close >= march_close,
        "{close} of {both} pixels within 0.005 r (march {march_close})"
    );
    assert_clean(&gpu);
}

/// An OBJ mesh in the background: scene depth equals the CPU ray cast of the same triangles (a tilted
/// quad and a tetrahedron), and the rest stays sky.
#[test]
fn background_mesh_depth_matches_cpu_ray_cast() {
    use glam::Vec3;
    let gpu = gpu();
    let (w, h) = (96usize, 64usize);
    let obj = b"v -1 -0.6 -0.5\nv 1 -0.6 0.2\nv 1 0.4 0.2\nv -1 0.4 -0.5\nf 1 2 3 4\n\
v 0.2 0.1 0.8\nv 0.6 0.1 0.8\nv 0.4 0.5 0.9\nv 0.4 0.2 1.2\nf 5 6 7\nf 5 6 8\nf 6 7 8\nf 5 7 8\n";
    let mesh = meniscus::scene::geometry::Geometry::parse_obj(obj).unwrap();
    let v = view([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], w as u32, h as u32, 45.0);
    let mut s = settings(0.05);
    s.filter.method = Filter::None;
    let mut r = Renderer::new(&gpu).unwrap();
    r.upload(meniscus::renderer::Upload::points(&[[10.0, 10.0, 10.0]])).unwrap();
    r.set_background(meniscus::renderer::Backdrop::Mesh(&mesh)).unwrap();
    r.render(&v, &s).unwrap();
    let depth = read_f32(&gpu, &r.state().targets().unwrap().scene_depth).unwrap();
    let inv = v.camera.view().inverse();
    let f = v.camera.focal_px(h as u32) as f64;
    let (mut hit, mut max_err, mut mismatch) = (0, 0f32, 0);
    for y in 0..h {
        for x in 0..w {
            let dv = pixel_dir(x, y, w, h, f);
            let d = inv.transform_vector3(Vec3::new(dv[0] as f32, dv[1] as f32, dv[2] as f32));
            let got = depth[y * w + x];
            match mesh.intersect(v.camera.eye, d) {
                Some((t, _)) if got.is_finite() => {
                    hit += 1;
                    max_err = max_err.max((got - t).abs());
                }
                None if got.is_infinite() => {}
                _ => mismatch += 1,
            }
        }
    }
    assert!(hit > 1000, "{hit} mesh pixels");
    // Pixels whose centre ray grazes a shared edge may differ.
    assert!(mismatch <= 4, "{mismatch} pixels disagree on coverage");
    assert!(max_err < 1e-4, "max depth error {max_err}");
    assert_clean(&gpu);
}

/// A sphere in the background (a simulation's moving body): scene depth equals the CPU's ray–sphere
/// intersection, and without it those pixels are sky (the control).
#[test]
fn background_sphere_depth_matches_cpu_ray_cast() {
    use glam::Vec3;
    let gpu = gpu();
    let (w, h) = (96usize, 64usize);
    let (c, radius) = (Vec3::new(0.3, -0.1, 0.2), 0.6f32);
    let mut v = view([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], w as u32, h as u32, 45.0);
    let mut s = settings(0.05);
    s.filter.method = Filter::None;
    let mut r = Renderer::new(&gpu).unwrap();
    r.upload(meniscus::renderer::Upload::points(&[[10.0, 10.0, 10.0]])).unwrap();
    let mut depth_with = |spheres: Vec<(Vec3, f32)>| {
        v.env.spheres = spheres;
        r.render(&v, &s).unwrap();
        read_f32(&gpu, &r.state().targets().unwrap().scene_depth).unwrap()
    };
    let without = depth_with(vec![]);
    let depth = depth_with(vec![(c, radius)]);
    let inv = v.camera.view().inverse();
    let f = v.camera.focal_px(h as u32) as f64;
    let (mut hit, mut max_err, mut mismatch, mut sky) = (0, 0f32, 0, 0);
    for y in 0..h {
        for x in 0..w {
            let dv = pixel_dir(x, y, w, h, f);
            let d = inv.transform_vector3(Vec3::new(dv[0] as f32, dv[1] as f32, dv[2] as f32));
            // |o + t d − c|² = r²: the nearer root (depth along the view axis: d's view-space z is −1).
            let oc = v.camera.eye - c;
            let (a, b, q) = (d.dot(d), oc.dot(d), oc.dot(oc) - radius * radius);
            let disc = b * b - a * q;
            let want = (disc >= 0.0).then(|| (-b - disc.sqrt()) / a).filter(|t| *t > 0.0);
            let got = depth[y * w + x];
            match want {
                Some(t) if got.is_finite() => {
                    hit += 1;
                    max_err = max_err.max((got - t).abs());
                    sky += without[y * w + x].is_infinite() as usize;
                }
                None if got.is_infinite() => {}
                _ => mismatch += 1,
            }
        }
    }
    assert!(hit > 700, "{hit} sphere pixels");
    assert!(mismatch <= 4, "{mismatch} pixels disagree on coverage");
    assert!(max_err < 1e-4, "max depth error {max_err}");
    assert_eq!(sky, hit, "without the sphere its pixels are sky");
    assert_clean(&gpu);
}

/// The splat's occlusion pre-pass (`splat_cull`, on when spheres span tiles) changes nothing: a dense block
/// of large spheres splats bit-identically to the rasterised MIN-blend variant, which has no culling.
/// The compute splat counts its work: without the occlusion cull, one sphere–pixel test per pixel of each
/// drawn sphere's screen rectangle (the CPU's `sphere_bounds`; a rectangle's edge may round the other way on
/// another device's arithmetic: within 0.5 %); with it, fewer tests and skipped tiles, and the same depth.
#[test]
fn the_splat_counts_its_sphere_pixel_tests() {
    let gpu = gpu();
    // The GPU's counts of a scene's splat, and the CPU's: the pixels of every on-screen sphere's rectangle, and
    // those spheres.
    let counted = |scene: &str, n: usize, (w, h): (u32, u32), closer: f32| {
        let (g, v) = splat_scene(scene, n, w, h, 0.0, closer);
        let mut s = settings(g.radius);
        s.filter.method = Filter::None;
        let mut r = Renderer::new(&gpu).unwrap();
        r.upload(meniscus::renderer::Upload::points(&g.particles.positions)).unwrap();
        render_counted(&mut r, &v, &s).unwrap();
        let work = r.state().targets().unwrap().splat_work(&gpu).unwrap();
        let (view_m, f, radius) = (v.camera.view(), v.camera.focal_px(h), g.radius * s.splat_scale());
        let (mut tests, mut spheres) = (0u64, 0u64);
        for p in &g.particles.positions {
            let c = view_m.transform_point3(glam::Vec3::from(*p)).to_array();
            if let Some((lo, hi)) = sphere_bounds(c, radius, w as usize, h as usize, f, v.camera.near) {
                tests += ((hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1)) as u64;
                spheres += 1;
            }
        }
        (work, tests, spheres)
    };
    // Far: no cull (spheres under half a tile).
    let (work, tests, spheres) = counted("drop", 3000, (96, 64), 1.0);
    eprintln!("splat: {work:?}; the CPU's rectangles: {tests} tests, {spheres} spheres");
    assert!(spheres > 1000 && spheres <= 3000, "{spheres} spheres on screen");
    assert!(work.spheres.abs_diff(spheres) <= spheres / 200, "{work:?}: {spheres} spheres");
    assert!(work.tests.abs_diff(tests) <= tests / 200, "{work:?}: {tests} tests");
    assert_eq!(work.tiles_skipped, 0, "no cull at this size");
    // Close up: the occlusion cull skips the tiles where a sphere is hidden.
    let (culled, all, _) = counted("block", 4000, (320, 240), 0.45);
    assert!(culled.tiles_skipped > 1000, "{culled:?}");
    eprintln!("culled splat: {culled:?}; {all} tests without the cull");
    assert!(culled.tests < all / 2, "the cull removes most tests: {culled:?} of {all}");
    assert_clean(&gpu);
}

/// The compute splat's lanes per large sphere (`[splat] lanes`: 32 by default on GPUs, 1 on lavapipe) change who
/// walks a sphere's pixels, not the depth: on the culled close-up block the depth of 1, 8 and 32 lanes is
/// bit-identical, and so are the work counts (tests, spheres, tiles skipped). Control: a larger `radius_scale`
/// changes the depth (the comparison sees a change).
#[test]
fn the_splat_lanes_per_sphere_change_nothing_but_time() {
    let gpu = gpu();
    let (g, v) = splat_scene("block", 4000, 320, 240, 0.0, 0.45);
    let run = |lanes: u32, scale: f32| {
        let mut s = settings(g.radius);
        s.filter.method = Filter::None;
        s.splat.lanes = lanes;
        s.splat.radius_scale = scale;
        let mut r = Renderer::new(&gpu).unwrap();
        *r.parts_mut().keep_raw_depth = true;
        r.upload(meniscus::renderer::Upload::points(&g.particles.positions)).unwrap();
        render_counted(&mut r, &v, &s).unwrap();
        let t = r.state().targets().unwrap();
        (read_f32(&gpu, &t.depth).unwrap(), t.splat_work(&gpu).unwrap())
    };
    let scale = settings(g.radius).splat.radius_scale;
    let (one, w1) = run(1, scale);
    assert!(w1.tiles_skipped > 0, "the close-up must take the culled path: {w1:?}");
    for lanes in [8, 32] {
        let (d, w) = run(lanes, scale);
        assert!(d.iter().zip(&one).all(|(a, b)| a.to_bits() == b.to_bits()), "{lanes} lanes changed the depth");
        assert_eq!((w.tests, w.spheres, w.tiles_skipped), (w1.tests, w1.spheres, w1.tiles_skipped), "{lanes} lanes");
    }
    let (bigger, _) = run(32, scale * 1.2);
    assert!(bigger.iter().zip(&one).any(|(a, b)| a.to_bits() != b.to_bits()), "the comparison cannot see a change");
    assert_clean(&gpu);
}

#[test]
fn occlusion_culled_splat_equals_unculled_raster() {
    use meniscus::named::SplatMode;
    let gpu = gpu();
    // Close up: the block fills the view and its spheres span several tiles.
    let (g, v) = splat_scene("block", 4000, 320, 240, 0.0, 0.45);
    let dist = (v.camera.eye - v.camera.target).length();
    let px = v.camera.focal_px(v.height) * g.radius * settings(g.radius).splat_scale() / dist;
    assert!(meniscus::passes::splat::cull_pays(px), "spheres of {px} px must take the culled path");
    let culled = splat_depth(&gpu, &g.particles.positions, g.radius, &v, SplatMode::Compute).unwrap();
    let raster = splat_depth(&gpu, &g.particles.positions, g.radius, &v, SplatMode::QuadMin).unwrap();
    assert!(culled.iter().filter(|d| d.is_finite()).count() > 5000);
    assert_same_depth(&culled, &raster, "culled compute vs quad-min");
    assert_clean(&gpu);
}

/// f32 → IEEE half bits, for values exactly representable (k/64 in [0, 1]; +inf).
fn f16_bits(x: f32) -> u16 {
    if x == 0.0 {
        return 0;
    }
    if x.is_infinite() {
        return 0x7c00;
    }
    let b = x.to_bits();
    let exp = ((b >> 23) & 0xff) as i32 - 127 + 15;
    (((b >> 16) & 0x8000) | ((exp as u32) << 10) | ((b >> 13) & 0x3ff)) as u16
}

/// The composite pass alone against a CPU reference of composite.comp on controlled inputs: a fluid plane at
/// depth 2 with a tilted normal in front of a background whose red channel ramps left to right, thickness
/// growing left to right. Checks Beer–Lambert (exp(−η·T) per channel), the refraction offset n.xy·min(T·α, β)
/// into the ramp, the transparency mix τ = exp(−γ·T), Schlick's Fresnel from the per-pixel view angle, and the
/// gamma encoding — every output channel within 1.5 levels of 255.
#[test]
fn composite_matches_cpu_reference() {
    use meniscus::passes::composite::CompositeInputs;
    let gpu = gpu();
    let (w, h) = (64usize, 32usize);
    let v = view([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], w as u32, h as u32, 40.0);
    let mut s = settings(0.05);
    s.composite.reflect_sky = false;
    s.composite.specular = 0.0;
    s.thickness.scale = 1.0;
    s.composite.refraction_alpha = 40.0;
    s.composite.refraction_beta = 6.0;
    let mut r = Renderer::new(&gpu).unwrap();
    r.upload(meniscus::renderer::Upload::points(&[[0.0, 0.0, 0.0]])).unwrap();
    pass_targets(&mut r, &v, &s);
    let t = r.state().targets().unwrap();
    // Background: red = x/64, green 0.5, blue 0.25; nothing in front of the fluid.
    let bg = |x: usize| [x as f32 / 64.0, 0.5, 0.25];
    let mut scene = vec![0u16; w * h * 4];
    for y in 0..h {
        for x in 0..w {
            let c = bg(x);
            scene[4 * (y * w + x)..4 * (y * w + x) + 4].copy_from_slice(&[
                f16_bits(c[0]),
                f16_bits(c[1]),
                f16_bits(c[2]),
                f16_bits(1.0),
            ]);
        }
    }
    upload_image(&gpu, &t.scene_color, bytemuck::cast_slice(&scene)).unwrap();
    upload_image(&gpu, &t.scene_depth, bytemuck::cast_slice(&vec![f32::INFINITY; w * h])).unwrap();
    let d = 2.0f32;
    upload_image(&gpu, &t.depth, bytemuck::cast_slice(&vec![d; w * h])).unwrap();
    // Normal (0.6, 0, 0.8), octahedral snorm16 (as normals.comp packs it).
    let n_bits: u32 = (0.6f32 / 1.4 * 32767.0).round() as u32 & 0xffff;
    upload_image(&gpu, &t.normals, bytemuck::cast_slice(&vec![n_bits; w * h])).unwrap();
    let thick: Vec<f32> = (0..w * h).map(|i| (i % w) as f32 * 0.003).collect();
    upload_image(&gpu, &t.thickness, bytemuck::cast_slice(&thick)).unwrap();
    upload_image(&gpu, &t.ssr, bytemuck::cast_slice(&vec![meniscus::passes::ssr::MISS; w * h])).unwrap();
    gpu.one_shot(|cmd| {
        let mut ctx = FrameCtx::new(&gpu, cmd, None);
        let inputs = CompositeInputs {
            scene_color: &t.scene_color,
            scene_depth: &t.scene_depth,
            depth: &t.depth,
            normals: &t.normals,
            thickness: &t.thickness,
            ssr: &t.ssr,
            sky: &r.state().background().sky,
        };
        // No layers: the shading alone.
        r.state().passes().composite.record(&mut ctx, r.state().uniforms(), &inputs, &[], &t.final_color)?;
        Ok(())
    })
    .unwrap();
    let out = read_image(&gpu, &t.final_color).unwrap();
    let n = meniscus::passes::normals::unpack(n_bits);
    let f = v.camera.focal_px(h as u32) as f64;
    let eta: Vec<f64> = s.composite.extinction.iter().map(|e| (*e * s.composite.extinction_scale) as f64).collect();
    let mut worst = 0f64;
    for y in 0..h {
        for x in 0..w {
            let tt = thick[y * w + x] as f64;
            let atten: Vec<f64> = eta.iter().map(|e| (-e * tt).exp()).collect();
            let off = n[0] as f64 * (tt * s.composite.refraction_alpha as f64).min(s.composite.refraction_beta as f64);
            let rx = ((x as f64 + off) as i64).clamp(0, w as i64 - 1) as usize;
            let c_refract: Vec<f64> = (0..3).map(|k| bg(rx)[k] as f64 * atten[k]).collect();
            let c_fluid: Vec<f64> =
                (0..3).map(|k| (s.composite.fluid_color[k] * s.composite.ambient) as f64 * atten[k]).collect();
            let tau = (-(s.composite.transparency_gamma as f64) * tt).exp();
            let dir = pixel_dir(x, y, w, h, f);
            let len = (dir[0] * dir[0] + dir[1] * dir[1] + 1.0).sqrt();
            let vdir = [-dir[0] / len, -dir[1] / len, -dir[2] / len];
            let ndv = (n[0] as f64 * vdir[0] + n[1] as f64 * vdir[1] + n[2] as f64 * vdir[2]).max(0.0);
            let f0 = s.composite.f0 as f64;
            let fres = f0 + (1.0 - f0) * (1.0 - ndv).powi(5);
            for k in 0..3 {
                let c = c_fluid[k] * (1.0 - tau) + c_refract[k] * (1.0 - fres) * tau;
                let want = c.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0;
                let got = out[4 * (y * w + x) + k] as f64;
                worst = worst.max((got - want).abs());
            }
        }
    }
    assert!(worst <= 1.5, "composite differs from the CPU reference by {worst:.2} levels");
    assert_clean(&gpu);
}

/// The thickness blur (second dispatch of `thickness`) against a CPU 2D Gaussian of the unblurred thickness:
/// same radius, sigma = radius/2, clamped borders.
#[test]
fn thickness_blur_matches_cpu_gaussian() {
    let gpu = gpu();
    let (w, h) = (48usize, 40usize);
    let v = view([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], w as u32, h as u32, 40.0);
    let mut s = settings(0.3);
    s.thickness.scale = 1.0;
    let particles = [[0.0, 0.0, 0.0], [0.5, 0.2, -0.3], [-0.4, -0.3, 0.2]];
    let render = |blur: u32| {
        let mut s = s.clone();
        s.thickness.blur_px = blur;
        let r = rendered(&gpu, &particles, &v, &s, false);
        read_f32(&gpu, &r.state().targets().unwrap().thickness).unwrap()
    };
    let raw = render(0);
    let radius = 3i64;
    let blurred = render(radius as u32);
    let sigma = (radius as f64 * 0.5).max(0.5);
    let k = 1.0 / (2.0 * sigma * sigma);
    let mut worst = 0f64;
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let (mut sum, mut wsum) = (0f64, 0f64);
            for dy in -radius..=radius {
                for dx in -radius..=radius {
                    let qx = (x + dx).clamp(0, w as i64 - 1) as usize;
                    let qy = (y + dy).clamp(0, h as i64 - 1) as usize;
                    let wt = (-((dx * dx + dy * dy) as f64) * k).exp();
                    sum += wt * raw[qy * w + qx] as f64;
                    wsum += wt;
                }
            }
            worst = worst.max((blurred[y as usize * w + x as usize] as f64 - sum / wsum).abs());
        }
    }
    let peak = raw.iter().fold(0f32, |a, b| a.max(*b)) as f64;
    assert!(peak > 0.3, "the test spheres must show ({peak})");
    assert!(worst < 1e-4 * peak.max(1.0), "blur differs from the CPU Gaussian by {worst}");
    assert_clean(&gpu);
}

/// The barrier batching the access table drives: reads after reads need no barrier, a write after a read and
/// a read after a write need one batch each, and one call flushes at most one batch.
#[test]
fn barrier_batches_follow_the_access_table() {
    use meniscus::gpu::{Access, Use};
    let gpu = gpu();
    let v = view([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], 16, 16, 40.0);
    let s = settings(0.3);
    let r = rendered(&gpu, &[[0.0, 0.0, 0.0]], &v, &s, false);
    let t = r.state().targets().unwrap();
    let counts = gpu
        .one_shot(|cmd| {
            let mut ctx = FrameCtx::new(&gpu, cmd, None);
            let mut seen = vec![];
            ctx.barrier(&[Use::Image(&t.normals, Access::ComputeWrite, true), Use::read(&t.ssr)]);
            seen.push(ctx.barrier_batches); // write after the frame's reads, ssr read after its write: 1 batch
            ctx.barrier(&[Use::read(&t.ssr)]);
            seen.push(ctx.barrier_batches); // read after read: nothing
            ctx.barrier(&[Use::read(&t.normals), Use::read(&t.ssr)]);
            seen.push(ctx.barrier_batches); // read after write (normals): 1 more
            ctx.barrier(&[Use::read(&t.normals)]);
            seen.push(ctx.barrier_batches); // nothing
            Ok(seen)
        })
        .unwrap();
    assert_eq!(counts, vec![1, 1, 2, 2]);
    assert_clean(&gpu);
}

/// Issue #14: the extracted mesh ray-cast through its BVH (`surface = "mesh"`, the `mesh` pass) gives the depth
/// of the `iso` pass's ray cast of the same field: they cover the same pixels (≥ 98 % agreement) and their depths
/// differ by less than 0.05 r at the median and 0.25 r at the 95th percentile (cube 0.25 r).
#[test]
fn mesh_depth_matches_iso_ray_cast() {
    let gpu = gpu();
    let (w, h) = (128usize, 96usize);
    let r = 0.05f32;
    let mut pts = jittered_slab(777, [12, 3, 8], [-0.55, -0.3, -0.4], r, [1.0; 3]);
    pts.push([0.1, 0.4, 0.0]); // a lone droplet
    let v = view([0.3, 1.2, 2.4], [0.0, 0.0, 0.0], w as u32, h as u32, 45.0);
    let depth_of = |surface: meniscus::settings::Surface| {
        let mut s = settings(r);
        s.filter.method = Filter::None;
        s.surface = surface;
        s.mesh.cube = 0.25;
        let mut rd = Renderer::new(&gpu).unwrap();
        rd.upload(meniscus::renderer::Upload::points(&pts)).unwrap();
        let times = rd.render(&v, &s).unwrap();
        if surface == meniscus::settings::Surface::Mesh {
            assert!(times.get("mesh").is_some() && times.get("splat").is_none(), "{times:?}");
        }
        read_f32(&gpu, &rd.state().targets().unwrap().depth).unwrap()
    };
    let iso = depth_of(meniscus::settings::Surface::Iso);
    let mesh = depth_of(meniscus::settings::Surface::Mesh);
    let DepthDiff { same, fluid, median, p95 } = depth_diff(&iso, &mesh, r);
    assert!(fluid > 1000, "only {fluid} fluid pixels");
    assert!(same as f32 >= 0.98 * (w * h) as f32, "coverage agrees on {same} of {} pixels", w * h);
    eprintln!("mesh vs iso depth: median {median:.4} r, p95 {p95:.4} r over {fluid} pixels");
    assert!(median < 0.05 && p95 < 0.25, "mesh vs iso depth: median {median} r, p95 {p95} r");
    assert_clean(&gpu);
}

/// The mesh surface of `pts` (radius 0.05, the test view) extracted where `extraction` says, smoothed `iters`
/// times: its fluid depth, final image and (vertices, triangles).
fn mesh_surface(
    gpu: &std::sync::Arc<meniscus::gpu::Gpu>,
    pts: &[[f32; 3]],
    extraction: meniscus::surface::mesh::params::Extraction,
    iters: u32,
) -> (Vec<f32>, image::RgbaImage, (usize, usize)) {
    use meniscus::surface::mesh::{params::Extraction, FluidMesh};
    let v = view([0.3, 1.2, 2.4], [0.0, 0.0, 0.0], 128, 96, 45.0);
    let mut s = settings(0.05);
    s.surface = meniscus::settings::Surface::Mesh;
    s.mesh.extraction = extraction;
    s.mesh.smoothing_iters = iters;
    let mut rd = Renderer::new(gpu).unwrap();
    rd.upload(meniscus::renderer::Upload::points(pts)).unwrap();
    let times = rd.render(&v, &s).unwrap();
    let st = rd.state();
    let mesh = st.surfaces().technique::<FluidMesh>().unwrap();
    assert_eq!(mesh.path().unwrap().0, extraction, "{:?}", mesh.path());
    let counts = match extraction {
        Extraction::Gpu => {
            assert!(times.get("mc_field").is_some() && times.get("mesh").is_some(), "{times:?}");
            assert_eq!(times.get("mesh_smooth").is_some(), iters > 0, "{times:?}");
            let work = mesh.live_work().unwrap();
            assert!(!work.outgrown && work.blocks > 0, "{work:?}");
            (work.vertices as usize, work.triangles as usize)
        }
        _ => mesh.mesh_stats().map(|(_, v, t)| (v, t)).unwrap(),
    };
    let depth = read_f32(gpu, &st.targets().unwrap().depth).unwrap();
    (depth, st.read_final().unwrap(), counts)
}

/// The jittered slab and lone droplet the mesh surface tests draw (radius 0.05).
fn mesh_test_particles() -> Vec<[f32; 3]> {
    let mut pts = jittered_slab(777, [12, 3, 8], [-0.55, -0.3, -0.4], 0.05, [1.0; 3]);
    pts.push([0.1, 0.4, 0.0]); // a lone droplet
    pts
}

/// Whether depth `d` is `reference`'s within the live mesh tests' gate: coverage on ≥ 99.5 % of the pixels, the
/// depth within `median` r at the median and `p95` r at the 95th percentile.
fn same_surface(reference: &[f32], d: &[f32], (median_max, p95_max): (f32, f32)) -> bool {
    let DepthDiff { same, fluid, median, p95 } = depth_diff(reference, d, 0.05);
    eprintln!("coverage {same} of {}, median {median:.6} r, p95 {p95:.6} r over {fluid}", d.len());
    fluid > 1000 && same as f32 >= 0.995 * d.len() as f32 && median < median_max && p95 < p95_max
}

/// The golden frame's tolerance: mean channel difference ≤ 2 levels, ≤ 0.5 % of pixels off by more than 24.
fn within_golden_tolerance(a: &image::RgbaImage, b: &image::RgbaImage) -> bool {
    let (mut sum, mut bad) = (0u64, 0usize);
    for (p, q) in a.pixels().zip(b.pixels()) {
        let d = (0..3).map(|c| p[c].abs_diff(q[c]) as u64).max().unwrap();
        sum += d;
        bad += (d > 24) as usize;
    }
    let n = (a.width() * a.height()) as f64;
    sum as f64 / n <= 2.0 && bad as f64 <= 0.005 * n
}

/// The live mesh surface (`[mesh] extraction = "gpu"`: the `mc` stages inside the frame on the renderer's grid,
/// the triangles drawn by the raster `mesh` pass from the device's buffers) draws the mesh the CPU extracts and
/// the BVH cast draws: the same triangle and vertex counts (the same lattice and blocks, found on the device),
/// coverage on ≥ 99.5 % of the pixels, depths within 0.002 r at the median and 0.02 r at the 95th percentile,
/// and the final image within the golden frame's tolerance. Control: the live mesh of the particles moved by
/// half a radius fails the depth gate.
#[test]
fn live_mesh_surface_draws_the_cpu_extracted_mesh() {
    use meniscus::surface::mesh::params::Extraction;
    let gpu = gpu();
    let pts = mesh_test_particles();
    let (cpu_depth, cpu_image, cpu_counts) = mesh_surface(&gpu, &pts, Extraction::Cpu, 0);
    let (gpu_depth, gpu_image, gpu_counts) = mesh_surface(&gpu, &pts, Extraction::Gpu, 0);
    assert_eq!(gpu_counts, cpu_counts, "(vertices, triangles) live vs CPU");
    let gate = (0.002, 0.02);
    assert!(same_surface(&cpu_depth, &gpu_depth, gate), "the live mesh's depth is not the CPU mesh's");
    assert!(within_golden_tolerance(&cpu_image, &gpu_image), "the live mesh's image is not the CPU mesh's");
    // Control: particles half a radius off draw another surface, which the gate rejects.
    let moved: Vec<[f32; 3]> = pts.iter().map(|p| [p[0], p[1] + 0.025, p[2]]).collect();
    let (moved_depth, _, _) = mesh_surface(&gpu, &moved, Extraction::Gpu, 0);
    assert!(!same_surface(&cpu_depth, &moved_depth, gate), "the gate passes a surface half a radius off");
    assert_clean(&gpu);
}

/// The live mesh's buffers grow when a frame needs more than they hold: with room for 0.001 triangles per cube, a
/// single frame (submitted and finished, no second try) reports itself outgrown and misses most of the surface
/// (the control: its depth fails the gate), the next frame grows the buffers and draws the CPU's mesh;
/// `Renderer::render` does that on its own (one call gives the whole mesh).
#[test]
fn the_live_mesh_grows_its_buffers_when_a_frame_needs_more() {
    use meniscus::renderer::FrameRequest;
    use meniscus::surface::mesh::{params::Extraction, FluidMesh};
    let gpu = gpu();
    let pts = mesh_test_particles();
    let (cpu_depth, _, cpu_counts) = mesh_surface(&gpu, &pts, Extraction::Cpu, 0);
    let v = view([0.3, 1.2, 2.4], [0.0, 0.0, 0.0], 128, 96, 45.0);
    let mut s = settings(0.05);
    s.surface = meniscus::settings::Surface::Mesh;
    s.mesh.extraction = Extraction::Gpu;
    s.mesh.live_triangles_per_cube = 0.001;
    let mut rd = Renderer::new(&gpu).unwrap();
    rd.upload(meniscus::renderer::Upload::points(&pts)).unwrap();
    let frame = |rd: &mut Renderer| {
        let sub = rd.submit(FrameRequest::new(&v, &s)).unwrap();
        rd.finish(sub).unwrap();
        let work = rd.state().surfaces().technique::<FluidMesh>().unwrap().live_work().unwrap();
        (read_f32(&gpu, &rd.state().targets().unwrap().depth).unwrap(), work)
    };
    let (first, work) = frame(&mut rd);
    assert!(work.outgrown, "{work:?}");
    assert!(!same_surface(&cpu_depth, &first, (0.002, 0.02)), "an outgrown frame drew the whole mesh");
    let (second, work) = frame(&mut rd);
    assert!(!work.outgrown && (work.vertices as usize, work.triangles as usize) == cpu_counts, "{work:?}");
    assert!(same_surface(&cpu_depth, &second, (0.002, 0.02)), "the grown buffers did not draw the CPU's mesh");
    let mut once = Renderer::new(&gpu).unwrap();
    once.upload(meniscus::renderer::Upload::points(&pts)).unwrap();
    once.render(&v, &s).unwrap();
    let depth = read_f32(&gpu, &once.state().targets().unwrap().depth).unwrap();
    assert!(same_surface(&cpu_depth, &depth, (0.002, 0.02)), "render() left an outgrown frame");
    assert_clean(&gpu);
}

/// `--preset smooth` live: the live mesh smoothed on the device (`compute::smooth`'s passes with the counts from
/// the device) draws the CPU's smoothed mesh — 24 and 25 iterations (the result in either position buffer),
/// feature weights on: coverage on ≥ 99.5 % of the pixels, depths within 0.0005 r at the median and 0.005 r at the
/// 95th percentile (the two meshes' vertices come in different orders, so their neighbour sums round apart),
/// the image within the golden tolerance. Control: the unsmoothed live mesh against the CPU's smoothed one fails.
#[test]
fn live_smoothed_mesh_surface_draws_the_cpu_smoothed_mesh() {
    use meniscus::surface::mesh::params::Extraction;
    let gpu = gpu();
    let pts = mesh_test_particles();
    let gate = (0.0005, 0.005);
    for iters in [24, 25] {
        let (cpu_depth, cpu_image, cpu_counts) = mesh_surface(&gpu, &pts, Extraction::Cpu, iters);
        let (gpu_depth, gpu_image, gpu_counts) = mesh_surface(&gpu, &pts, Extraction::Gpu, iters);
        assert_eq!(gpu_counts, cpu_counts, "{iters} iterations: (vertices, triangles) live vs CPU");
        assert!(same_surface(&cpu_depth, &gpu_depth, gate), "{iters} iterations: the depth differs");
        assert!(within_golden_tolerance(&cpu_image, &gpu_image), "{iters} iterations: the image differs");
        if iters == 25 {
            let (raw, _, _) = mesh_surface(&gpu, &pts, Extraction::Gpu, 0);
            assert!(!same_surface(&cpu_depth, &raw, gate), "the gate passes the unsmoothed mesh");
        }
    }
    assert_clean(&gpu);
}

/// How two depth images (linear depth, +inf = none) differ: pixels whose coverage agrees, pixels covered in
/// both, and the median and 95th percentile of their depth difference in units of `r`.
struct DepthDiff {
    same: usize,
    fluid: usize,
    median: f32,
    p95: f32,
}

fn depth_diff(a: &[f32], b: &[f32], r: f32) -> DepthDiff {
    let same = a.iter().zip(b).filter(|(x, y)| x.is_finite() == y.is_finite()).count();
    let mut diffs: Vec<f32> =
        a.iter().zip(b).filter(|(x, y)| x.is_finite() && y.is_finite()).map(|(x, y)| (x - y).abs() / r).collect();
    diffs.sort_by(f32::total_cmp);
    let at = |q: usize| diffs.get(diffs.len() * q / 100).copied().unwrap_or(f32::NAN);
    DepthDiff { same, fluid: diffs.len(), median: at(50), p95: at(95) }
}

/// Issue #15: `[mesh] smoothing_iters` (the `smooth` preset's surface) renders the smoothed mesh: the same
/// coverage as the raw mesh, depths moved by a fraction of a radius (the jittered slab's bumps smoothed), under
/// validation.
#[test]
fn smoothed_mesh_renders_near_the_raw_mesh() {
    let gpu = gpu();
    let (w, h) = (128usize, 96usize);
    let r = 0.05f32;
    let pts = jittered_slab(4321, [10, 3, 8], [-0.45, -0.3, -0.4], r, [1.0; 3]);
    let v = view([0.3, 1.2, 2.4], [0.0, 0.0, 0.0], w as u32, h as u32, 45.0);
    let mut rd = Renderer::new(&gpu).unwrap();
    rd.upload(meniscus::renderer::Upload::points(&pts)).unwrap();
    let mut depth_of = |iters: u32| {
        let mut s =
            meniscus::settings::Settings { radius: r, ..meniscus::settings::Settings::preset("smooth").unwrap() };
        s.mesh.smoothing_iters = iters;
        rd.render(&v, &s).unwrap();
        read_f32(&gpu, &rd.state().targets().unwrap().depth).unwrap()
    };
    let raw = depth_of(0);
    let smooth = depth_of(10);
    let DepthDiff { same, fluid, median, p95 } = depth_diff(&raw, &smooth, r);
    assert!(fluid > 1000, "only {fluid} fluid pixels");
    assert!(same as f32 >= 0.97 * (w * h) as f32, "coverage agrees on {same} of {} pixels", w * h);
    eprintln!("smoothed vs raw mesh depth: median {median:.4} r, p95 {p95:.4} r");
    assert!(p95 > 0.01, "smoothing moved nothing");
    assert!(median < 0.25 && p95 < 1.0, "smoothed vs raw mesh: median {median} r, p95 {p95} r");
    assert_clean(&gpu);
}

/// Issue #14: the GPU marching cubes (`mc` pass) give the CPU block path's mesh — the same triangles over the
/// same welded vertices, positions within 1e-3 of a cube edge, normals within 1° — for random clouds (SPH and
/// metaball fields, cubes 0.5 r and 1 r) and, when the shared data is here, the dam-break 6,859 frame 40; the
/// meshes are closed and consistently oriented, and the run is free of validation messages.
#[test]
fn gpu_marching_cubes_match_the_cpu_blocks() {
    use meniscus::field::extract::blocks::extract_blocks_keyed;
    use meniscus::field::extract::{open_or_flipped_edges, ExtractParams, TriMesh};
    // The GPU and the CPU blocks each number their vertices in their own order: both compared in edge-key order.
    let key_order = |m: &TriMesh, keys: &[i64], what: &str| {
        m.in_key_order(keys).unwrap_or_else(|| panic!("{what}: an edge has two vertices"))
    };
    use meniscus::field::iso::IsoGrid;
    let gpu = gpu();
    let mc = meniscus::compute::mc::Mc::new(&gpu).unwrap();
    let mut seed = 4242u32;
    let mut rnd = || {
        seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
        (seed >> 8) as f32 / (1u32 << 24) as f32
    };
    let r = 0.05f32;
    let mut cases: Vec<(String, Vec<[f32; 3]>, f32)> = vec![];
    for n in [1usize, 60, 700] {
        let pts: Vec<[f32; 3]> = (0..n).map(|_| [rnd() * 0.6, rnd() * 0.3, rnd() * 0.4]).collect();
        cases.push((format!("random {n}"), pts, r));
    }
    if let Some(f) = common::shared_data("splishsplash/dambreak_6859/partio/ParticleData_Fluid_40.bgeo") {
        let p = meniscus::scene::load(&f).unwrap();
        cases.push(("dam break 6,859 f40".into(), p.positions, 0.025));
    }
    for (label, pts, r) in &cases {
        for (cube, metaball) in [(0.5, false), (1.0, false), (1.0, true)] {
            let support = if metaball { 3.0 * r } else { 4.0 * r };
            let grid = IsoGrid::build(pts, support);
            let inv = grid.inv_density();
            let threshold = if metaball { meniscus::field::extract::metaball_threshold(*r, support) } else { 0.6 };
            let p = ExtractParams { metaball, ..ExtractParams::new(cube * r, threshold) };
            let what = format!("{label}, cube {cube} r, metaball {metaball}");
            let (cm, ckeys, _) = extract_blocks_keyed(&grid, &inv, &p);
            let (gm, keys, st) = mc.extract_keyed(&gpu, &grid, &inv, &p).unwrap();
            assert!(!cm.triangles.is_empty(), "{what}: empty");
            assert_eq!(gm.vertices.len(), cm.vertices.len(), "{what}: vertices");
            assert_eq!(gm.triangles.len(), cm.triangles.len(), "{what}: triangles");
            // Both in edge-key order (each edge once: the welds are exact), then the same triangles.
            let (m, cpu) = (key_order(&gm, &keys, &what), key_order(&cm, &ckeys, &what));
            assert_eq!(m.triangles, cpu.triangles, "{what}: triangles");
            let h = cube * r;
            // Vertices agree to 1e-3 of a cube, or — where the crossing is flat, so that the field's rounding
            // (summation order, fused multiply-adds: lavapipe and NVIDIA differ) moves the interpolated vertex
            // more — to the bound the arithmetic gives: h · 2δ / |v1 − v0| with δ = 256 ε · max(|v0|, |v1|, 1)
            // the field values' rounding (a few hundred terms of at most 1 each).
            let mut dmax = 0f32;
            let mut conditioned = 0;
            for (a, b) in m.vertices.iter().zip(&cpu.vertices) {
                let d = (0..3).map(|k| (a[k] - b[k]).abs()).fold(0f32, f32::max);
                dmax = dmax.max(d);
                if d > 1e-3 * h {
                    let (v0, v1) = meniscus::field::extract::edge_values(&grid, &inv, &p, *b);
                    let delta = 256.0 * f32::EPSILON * v0.abs().max(v1.abs()).max(1.0);
                    let bound = h * 2.0 * delta / (v1 - v0).abs().max(1e-30);
                    assert!(d <= 1e-3 * h + bound, "{what}: vertex {b:?} {d} apart (cube {h}; edge {v0} → {v1})");
                    conditioned += 1;
                }
            }
            let worst = m
                .normals
                .iter()
                .zip(&cpu.normals)
                .map(|(a, b)| (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]).clamp(-1.0, 1.0).acos().to_degrees())
                .fold(0f32, f32::max);
            assert!(worst < 1.0, "{what}: normals up to {worst}° apart");
            // The CPU path's own count (the same triangles): 0 on the random clouds; see docs/mesh-extraction.md on the frame.
            let (open, open_cpu) = (open_or_flipped_edges(&m), open_or_flipped_edges(&cpu));
            assert_eq!(open, open_cpu, "{what}: open or flipped edges");
            if label.starts_with("random") {
                assert_eq!(open, 0, "{what}: open or flipped edges");
            }
            assert!(st.gpu.get("mc_field").is_some() && st.gpu.get("mc_emit").is_some(), "{:?}", st.gpu);
            eprintln!(
                "{what}: {} triangles, {} blocks, {open} open edges, vertices up to {dmax} apart ({conditioned} past \
                 1e-3 of a cube, within their edge's conditioning), GPU {:?}",
                m.triangles.len(),
                st.blocks,
                st.gpu
            );
        }
    }
    // A threshold above the field's peak: no cube crosses it, an empty mesh (and no zero-sized copies).
    let grid = IsoGrid::build(&cases[0].1, 4.0 * r);
    let inv = grid.inv_density();
    let (m, _) = mc.extract(&gpu, &grid, &inv, &ExtractParams::new(0.5 * r, 10.0)).unwrap();
    assert!(m.triangles.is_empty() && m.vertices.is_empty());
    assert_clean(&gpu);
}

/// Ellipsoid splats (`--kernel anisotropic` on spheres): the splat of a tilted lattice (flat kernels) and a lone
/// particle (a sphere) equals the exact ray–ellipsoid entry depth of the CPU reference's kernels,
/// {x : |M (x − c)| ≤ R ∛det M}, solved in f64; the thickness equals the sum of the chords through them.
#[test]
fn ellipsoid_splat_matches_analytic_ray_ellipsoid() {
    use glam::Vec3;
    use meniscus::field::iso::IsoGrid;
    let gpu = gpu();
    let (w, h) = (128usize, 96usize);
    let r = 0.05f32;
    let n = Vec3::new(0.2, 1.0, 0.3).normalize();
    let (u, t) = (n.any_orthonormal_vector(), n.cross(n.any_orthonormal_vector()));
    let mut pts = vec![];
    for i in -5..=5 {
        for j in -5..=5 {
            pts.push(((u * i as f32 + t * j as f32) * 2.0 * r).to_array());
        }
    }
    pts.push([0.0, 0.6, 0.0]);
    let v = view([0.2, 1.4, 1.8], [0.0, 0.0, 0.0], w as u32, h as u32, 45.0);
    let mut s = settings(r);
    s.filter.method = Filter::None;
    s.kernel = meniscus::settings::Kernel::Anisotropic;
    s.anisotropy.min_neighbours = 8;
    s.thickness.scale = 1.0;
    s.thickness.blur_px = 0;
    let mut rd = Renderer::new(&gpu).unwrap();
    *rd.parts_mut().keep_raw_depth = true;
    rd.upload(meniscus::renderer::Upload::points(&pts)).unwrap();
    rd.render(&v, &s).unwrap();
    let got = read_f32(&gpu, &rd.state().targets().unwrap().depth).unwrap();
    let thick = read_f32(&gpu, &rd.state().targets().unwrap().thickness).unwrap();

    let grid = IsoGrid::build_reaching(&pts, s.iso.support * r, s.iso_reach());
    let kernels = grid.anisotropy(&s.iso_params().aniso.unwrap());
    let flat = kernels.iter().filter(|k| k.det() > 2.0).count();
    assert!(flat > 60, "{flat} flat kernels");
    let big_r = (r * s.splat.radius_scale) as f64;
    let inv_view = v.camera.view().inverse();
    let eye = v.camera.eye.as_dvec3();
    let f = v.camera.focal_px(h as u32) as f64;
    let (mut both, mut mismatch, mut close, mut thick_ok, mut thick_px) = (0, 0, 0, 0, 0);
    for y in 0..h {
        for x in 0..w {
            let dv = pixel_dir(x, y, w, h, f);
            let dir = inv_view.transform_vector3(Vec3::new(dv[0] as f32, dv[1] as f32, dv[2] as f32)).as_dvec3();
            // Entry and exit depth of the ray through each kernel's ellipsoid of the sphere of radius `big`.
            let hits = |big: f64| {
                kernels.iter().filter_map(move |k| {
                    let m = k.matrix().as_dmat3();
                    let rho = big * (k.det() as f64).cbrt();
                    let (a, b) = (m * dir, m * (eye - k.centre().as_dvec3()));
                    let (aa, ab) = (a.dot(a), a.dot(b));
                    let disc = ab * ab - aa * (b.dot(b) - rho * rho);
                    (disc >= 0.0).then(|| ((-ab - disc.sqrt()) / aa, (-ab + disc.sqrt()) / aa))
                })
            };
            let want = hits(big_r).map(|h| h.0).fold(f64::INFINITY, f64::min);
            // Thickness: the chords through the ellipsoids of the particles' own volume.
            let chord: f64 = hits(r as f64).map(|(a, b)| (b - a) * dir.length()).sum();
            if chord > 0.0 {
                thick_px += 1;
                if (thick[y * w + x] as f64 - chord).abs() < 0.01 * r as f64 {
                    thick_ok += 1;
                }
            }
            let g = got[y * w + x] as f64;
            match (want.is_finite(), g.is_finite()) {
                (true, true) => {
                    both += 1;
                    if (g - want).abs() < 0.01 * r as f64 {
                        close += 1;
                    }
                }
                (false, false) => {}
                _ => mismatch += 1,
            }
        }
    }
    eprintln!("ellipsoids: {both} pixels, {mismatch} differ in coverage, {close} within 0.01 r");
    assert!(both > 1000, "covered {both}");
    assert!(mismatch * 100 <= both, "coverage differs on {mismatch} of {both} pixels");
    assert!(close * 100 >= both * 99, "{close} of {both} pixels within 0.01 r");
    eprintln!("thickness: {thick_ok} of {thick_px} pixels within 0.01 r");
    assert!(thick_px > 1000 && thick_ok * 100 >= thick_px * 99, "thickness: {thick_ok} of {thick_px} within 0.01 r");
    assert_clean(&gpu);
}

/// The particles as the noise reference takes them: view-space centre, id, change of velocity.
fn noise_reference_particles(
    pos: &[[f32; 3]],
    motion: &[meniscus::motion::Motion],
    v: &meniscus::view::View,
) -> Vec<meniscus::passes::noise::reference::NoiseParticle> {
    let m = v.camera.view();
    pos.iter()
        .zip(motion)
        .map(|(p, mo)| meniscus::passes::noise::reference::NoiseParticle {
            c: m.transform_point3(glam::Vec3::from(*p)).to_array(),
            id: mo.id,
            accel: mo.accel,
        })
        .collect()
}

/// A slab of particles five layers deep (the lowest ones too deep to add noise), `n`×`n` per layer, spacing 2r, centred at the origin (y up).
fn noise_slab(n: usize, r: f32) -> Vec<[f32; 3]> {
    let mut p = vec![];
    for layer in 0..5 {
        for i in 0..n {
            for k in 0..n {
                let at = |j: usize| (j as f32 - (n as f32 - 1.0) / 2.0) * 2.0 * r;
                p.push([at(i), -(layer as f32) * 2.0 * r, at(k)]);
            }
        }
    }
    p
}

/// The tiled noise splat where sprites pile up on a tile (a surface seen at a grazing angle): each tile's list
/// is summed in chunks of NOISE_CHUNK sprites, a work group each, and the accumulator equals the per-sprite
/// splat's bit for bit (integer sums). The slab's top layer ten times, 0.02 r apart, seen from close
/// up: the longest list is past one chunk.
#[test]
fn tiled_noise_sums_long_tile_lists_in_chunks() {
    use meniscus::effect::noise::NoiseEffect;
    use meniscus::motion::Motion;
    let gpu = gpu();
    let r = 0.1f32;
    let v = view([0.2, 0.9, 1.1], [0.0, -0.2, 0.0], 160, 120, 60.0);
    let mut s = settings(r);
    s.filter.method = Filter::None;
    s.noise.enabled = true;
    let top: Vec<[f32; 3]> = noise_slab(14, r).into_iter().filter(|p| p[1] == 0.0).collect();
    let pos: Vec<[f32; 3]> =
        (0..10).flat_map(|k| top.iter().map(move |p| [p[0], p[1], p[2] + 0.02 * r * k as f32])).collect();
    let motion: Vec<Motion> = (0..pos.len()).map(|k| Motion { id: 7 * k as u32, accel: 0.0 }).collect();
    let mut runs = vec![];
    for tiled in [true, false] {
        let mut rr = Renderer::new(&gpu).unwrap();
        rr.parts_mut().effects.get_mut::<NoiseEffect>().unwrap().set_tiled(&gpu, tiled).unwrap();
        let up =
            meniscus::renderer::Upload::Points { positions: &pos, radii: None, isolated: None, motion: Some(&motion) };
        rr.upload(up).unwrap();
        render_counted(&mut rr, &v, &s).unwrap();
        let own = rr.state().effects().get::<NoiseEffect>().and_then(|n| n.images()).expect("the noise pass's images");
        runs.push((own.work().unwrap(), read_u32(&gpu, &own.accum).unwrap()));
    }
    let (tiled, alone) = (&runs[0], &runs[1]);
    eprintln!("{:?}", tiled.0);
    let chunk = meniscus::shader_constants::NOISE_CHUNK as u64;
    assert!(tiled.0.longest > chunk, "the longest list ({}) fits one chunk: the test misses its case", tiled.0.longest);
    assert_eq!(tiled.0.evaluated, alone.0.evaluated);
    assert!(tiled.1 == alone.1, "the chunked sums differ from the per-sprite splat's");
    assert_clean(&gpu);
}

/// N as the normals and the composite read it: level 0 of the noise's accumulator atlas in radii, 0 off the
/// fluid.
fn noise_n(
    gpu: &std::sync::Arc<meniscus::gpu::Gpu>,
    own: &meniscus::passes::noise::NoiseTargets,
    depth: &[f32],
) -> Vec<f32> {
    let (w, h) = own.size();
    let (w, aw) = (w as usize, own.accum.extent.width as usize);
    let atlas = read_u32(gpu, &own.accum).unwrap();
    let units = meniscus::passes::noise::UNITS;
    (0..w * h as usize)
        .map(|k| if depth[k] < 1e30 { atlas[(k / w) * aw + k % w] as i32 as f32 / units } else { 0.0 })
        .collect()
}

/// The `noise` pass's level of detail against the exact CPU reference: the slab seen from close up, so sprites
/// are tens to hundreds of pixels across and are evaluated on coarse levels of the accumulator, then resolved
/// bilinearly. The stated tolerance (docs/surface-detail.md), per `[noise] lod_samples`: over the covered
/// pixels, the mean difference is under 2 % of the peak |N| and 97 % of the pixels are within 10 % of the peak
/// at 6 samples per cycle (measured: 1.62 % and 97.6 %), under 3 % and 93 % at the default 4 (2.80 % and
/// 94.9 %); the differences are the bilinear reconstruction of the finer octave at that many samples per cycle,
/// and the depth a coarse texel reads for its 2^L × 2^L pixels. And the work it removes: fewer texels visited
/// than the reference's sprite pixels (1.6× at 6, 4.1× at 4 here; hundreds of times for a sprite hundreds of
/// pixels across).
#[test]
fn noise_level_of_detail_stays_within_tolerance_of_the_reference() {
    for (samples, mean_of_peak, within_percent) in [(6.0, 0.02, 97), (4.0, 0.03, 93)] {
        noise_level_of_detail_at(samples, mean_of_peak, within_percent);
    }
}

fn noise_level_of_detail_at(samples: f32, mean_of_peak: f32, within_percent: usize) {
    use meniscus::motion::Motion;
    use meniscus::passes::noise::{reference, UNITS};
    let gpu = gpu();
    let (w, h) = (160usize, 120usize);
    let r = 0.1f32;
    let v = view([0.2, 0.9, 1.1], [0.0, -0.2, 0.0], w as u32, h as u32, 60.0);
    let mut s = settings(r);
    s.filter.method = Filter::None;
    s.noise.enabled = true;
    s.noise.calm = 0.3;
    s.noise.turbulent = 0.9;
    s.noise.lod_samples = samples;
    let pos = noise_slab(14, r);
    let tau = s.noise.threshold;
    let motion: Vec<Motion> =
        (0..pos.len()).map(|k| Motion { id: 1000 + 7 * k as u32, accel: (k % 3) as f32 * tau }).collect();
    // Both splats (binned to tiles, as on a GPU; every sprite by its own thread, as on a CPU driver) give the
    // same sums.
    let mut runs = vec![];
    for tiled in [true, false] {
        let mut rr = Renderer::new(&gpu).unwrap();
        rr.parts_mut().effects.get_mut::<NoiseEffect>().unwrap().set_tiled(&gpu, tiled).unwrap();
        rr.upload(meniscus::renderer::Upload::Points {
            positions: &pos,
            radii: None,
            isolated: None,
            motion: Some(&motion),
        })
        .unwrap();
        render_counted(&mut rr, &v, &s).unwrap();
        let own = rr.state().effects().get::<NoiseEffect>().and_then(|n| n.images()).expect("the noise pass's images");
        let work = own.work().unwrap();
        let depth = read_f32(&gpu, rr.state().smoothed_depth().unwrap()).unwrap();
        let noise = noise_n(&gpu, own, &depth);
        let normals = read_u32(&gpu, &rr.state().targets().unwrap().normals).unwrap();
        runs.push((work, noise, depth, read_u32(&gpu, &own.accum).unwrap(), normals));
    }
    assert!(runs[0].3 == runs[1].3, "the two splats' accumulators differ");
    // Both splats ask for noise_resolve's work groups only when a coarse level was written (noise_scan for the
    // tiled one, noise_args for the other), and the normals read N at level 0 either way: the same N, coarse
    // levels included, and the same normals, bit for bit.
    assert!(runs[0].1 == runs[1].1, "N differs between the two splats");
    assert!(runs[0].4 == runs[1].4, "the normals differ between the two splats");
    let (a, b) = (runs[0].0, runs[1].0);
    assert_eq!((a.level, a.texels, a.sprites, a.evaluated), (b.level, b.texels, b.sprites, b.evaluated));
    assert!(a.binned > 0 && a.skipped == 0, "the close-up's large sprites go to the tiles: {a:?}");
    eprintln!("tiled splat: {} list entries, the longest list {} sprites", a.binned, a.longest);
    let (work, noise, depth, ..) = runs.pop().unwrap();
    let particles = noise_reference_particles(&pos, &motion, &v);
    let f = v.camera.focal_px(h as u32);
    let want = reference::accumulate(&particles, &depth, w, h, f, r, v.camera.near, &s.noise);
    // The reference's work: every pixel of every sprite's rectangle that is not culled at its centre.
    let ref_texels = reference::work(&particles, &depth, w, h, f, r, v.camera.near, &s.noise);
    let covered: Vec<usize> = (0..w * h).filter(|&k| depth[k] < 1e30).collect();
    let peak = covered.iter().map(|&k| (want[k] as f32 / UNITS).abs()).fold(0f32, f32::max);
    let diffs: Vec<f32> = covered.iter().map(|&k| (noise[k] - want[k] as f32 / UNITS).abs()).collect();
    let mean = diffs.iter().sum::<f32>() / diffs.len() as f32;
    let within = diffs.iter().filter(|d| **d <= 0.1 * peak).count();
    eprintln!(
        "noise LOD at {samples} samples per cycle: coarsest level {}, {} texels visited vs {ref_texels} reference pixels ({:.1}×), {} covered \
         pixels, peak {peak:.3} radii, mean difference {:.4} ({:.2} % of the peak), {:.2} % within 10 % of the peak",
        work.level,
        work.texels,
        ref_texels as f64 / work.texels as f64,
        covered.len(),
        mean,
        100.0 * mean / peak,
        100.0 * within as f32 / covered.len() as f32
    );
    assert!(work.level >= 2, "the close-up should use coarse levels: {work:?}");
    assert!(2 * ref_texels > 3 * work.texels, "the level of detail removes little work: {work:?} vs {ref_texels}");
    assert!(covered.len() > w * h / 2 && peak > 0.2, "too little to test: {} px, peak {peak}", covered.len());
    assert!(mean < mean_of_peak * peak, "mean difference {mean} against peak {peak} at {samples} samples per cycle");
    assert!(
        within * 100 >= covered.len() * within_percent,
        "{within} of {} pixels within 10 % of the peak at {samples} samples per cycle",
        covered.len()
    );
    assert_clean(&gpu);
}

/// The `noise` pass against its CPU reference (`passes::noise::reference`, the patent's eq. 15–17): a slab seen
/// from above at an angle, its particles calm, ramping and turbulent by their change of velocity, each seeded by
/// its own id. The accumulator equals the reference's fixed-point sums (up to float rounding of single terms),
/// N is the accumulator in radii, and the normals are the unperturbed ones minus N's slopes.
#[test]
fn noise_matches_cpu_reference() {
    use meniscus::motion::Motion;
    use meniscus::passes::noise::{reference, UNITS};
    let gpu = gpu();
    let (w, h) = (96usize, 64usize);
    let r = 0.1f32;
    let v = view([0.4, 2.2, 2.6], [0.0, 0.0, 0.0], w as u32, h as u32, 40.0);
    let mut s = settings(r);
    s.filter.method = Filter::None;
    s.noise.enabled = true;
    s.noise.calm = 0.2;
    s.noise.turbulent = 0.9;
    let pos = noise_slab(10, r);
    let tau = s.noise.threshold;
    let motion: Vec<Motion> =
        (0..pos.len()).map(|k| Motion { id: 1000 + 7 * k as u32, accel: (k % 3) as f32 * tau }).collect();
    let mut rr = Renderer::new(&gpu).unwrap();
    rr.upload(meniscus::renderer::Upload::Points {
        positions: &pos,
        radii: None,
        isolated: None,
        motion: Some(&motion),
    })
    .unwrap();
    render_counted(&mut rr, &v, &s).unwrap();
    let t = rr.state().targets().unwrap();
    let words = |img| read_u32(&gpu, img).unwrap();
    let own = rr.state().effects().get::<NoiseEffect>().and_then(|n| n.images()).expect("the noise pass's images");
    // Level 0 of the accumulator atlas: every sprite here is small enough to be evaluated at full resolution.
    let work = own.work().unwrap();
    assert_eq!(work.level, 0, "{work:?}");
    assert!(work.evaluated > 0 && work.evaluated <= work.texels, "{work:?}");
    let aw = own.accum.extent.width as usize;
    let atlas = words(&own.accum);
    let acc: Vec<i32> = (0..w * h).map(|k| atlas[(k / w) * aw + k % w] as i32).collect();
    let depth = read_f32(&gpu, rr.state().smoothed_depth().unwrap()).unwrap();
    let noise = noise_n(&gpu, own, &depth);
    let normals = words(&t.normals);
    // The other splat (tiles on a CPU driver, one thread per sprite on a GPU) gives the same atlas.
    let mut other = Renderer::new(&gpu).unwrap();
    let tiled = !rr.state().effects().get::<NoiseEffect>().unwrap().is_tiled();
    other.parts_mut().effects.get_mut::<NoiseEffect>().unwrap().set_tiled(&gpu, tiled).unwrap();
    other
        .upload(meniscus::renderer::Upload::Points {
            positions: &pos,
            radii: None,
            isolated: None,
            motion: Some(&motion),
        })
        .unwrap();
    other.render(&v, &s).unwrap();
    let own2 = other.state().effects().get::<NoiseEffect>().unwrap().images().unwrap();
    let atlas2 = words(&own2.accum);
    assert!(atlas2 == atlas, "the {} splat's accumulator differs", if tiled { "tiled" } else { "per-sprite" });
    // Level 0 alone: N is the sums themselves (no resolve) on either path; the same N and normals.
    assert!(noise_n(&gpu, own2, &depth) == noise, "the other path's N differs");
    assert!(words(&other.state().targets().unwrap().normals) == normals, "the other path's normals differ");
    let particles = noise_reference_particles(&pos, &motion, &v);
    let f = v.camera.focal_px(h as u32);
    let want = reference::accumulate(&particles, &depth, w, h, f, r, v.camera.near, &s.noise);
    let covered = depth.iter().filter(|d| **d < 1e30).count();
    let nonzero = want.iter().filter(|x| **x != 0).count();
    assert!(covered > 1000 && nonzero > covered / 2, "covered {covered}, noise on {nonzero}");
    let peak = want.iter().map(|x| x.abs()).max().unwrap();
    // Per pixel: a few units of 2^-16 radii from the rounding of each sprite's term (about 20 sprites a pixel).
    let worst = acc.iter().zip(&want).map(|(a, b)| (a - b).abs()).max().unwrap();
    eprintln!("noise: {nonzero} pixels, peak {:.3} radii, worst difference {worst} units", peak as f32 / UNITS);
    assert!(peak as f32 / UNITS > 0.2, "the noise is too weak to test: peak {peak}");
    assert!(worst <= 16, "accumulator differs from the CPU reference by {worst} units (2^-16 radii)");
    for k in 0..w * h {
        let want_n = if depth[k] < 1e30 { acc[k] as f32 / UNITS } else { 0.0 };
        assert_eq!(noise[k], want_n, "N at pixel {k}");
    }
    // The same frame without the pass: the unperturbed normals, then the normals' detail slopes (normals.comp,
    // NORMALS_DETAIL) on the CPU.
    let mut plain = Renderer::new(&gpu).unwrap();
    plain
        .upload(meniscus::renderer::Upload::Points {
            positions: &pos,
            radii: None,
            isolated: None,
            motion: Some(&motion),
        })
        .unwrap();
    plain.render(&v, &s.with(|s| s.noise.enabled = false)).unwrap();
    let n0 = words(&plain.state().targets().unwrap().normals);
    let edge = s.normals.edge * r;
    let same = |x: i64, y: i64, d: f32| {
        x >= 0 && y >= 0 && x < w as i64 && y < h as i64 && {
            let q = depth[y as usize * w + x as usize];
            q < 1e30 && (q - d).abs() < edge
        }
    };
    let hgt = |x: i64, y: i64| acc[y as usize * w + x as usize] as f32 / UNITS;
    let slope = |x: i64, y: i64, d: f32, (dx, dy): (i64, i64)| {
        let (fw, bw) = (same(x + dx, y + dy, d), same(x - dx, y - dy, d));
        match (fw, bw) {
            (true, true) => 0.5 * (hgt(x + dx, y + dy) - hgt(x - dx, y - dy)),
            (true, false) => hgt(x + dx, y + dy) - hgt(x, y),
            (false, true) => hgt(x, y) - hgt(x - dx, y - dy),
            _ => 0.0,
        }
    };
    let mut worst_deg = 0f32;
    let mut tilted = 0;
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let k = y as usize * w + x as usize;
            let d = depth[k];
            if !(d < 1e30) {
                continue;
            }
            let kk = s.noise.strength * r * f / d;
            let (gx, gy) = (slope(x, y, d, (1, 0)) * kk, -slope(x, y, d, (0, 1)) * kk);
            let a = glam::Vec3::from(meniscus::passes::normals::unpack(n0[k]));
            let want = (a - glam::Vec3::new(gx, gy, 0.0)).normalize();
            let got = glam::Vec3::from(meniscus::passes::normals::unpack(normals[k]));
            worst_deg = worst_deg.max(got.dot(want).clamp(-1.0, 1.0).acos().to_degrees());
            tilted += (got.dot(a).clamp(-1.0, 1.0).acos().to_degrees() > 1.0) as usize;
        }
    }
    eprintln!("normals: {tilted} of {covered} pixels tilted by more than 1°, worst error {worst_deg:.3}°");
    assert!(tilted > covered / 10, "the noise hardly moves the normals: {tilted} pixels");
    assert!(worst_deg < 0.1, "perturbed normals off by {worst_deg}°");
    assert_clean(&gpu);
}

/// Still water stays still: the same particles in consecutive frames of a sequence (no change of velocity)
/// give the same noise image and the same picture, frame after frame (the pattern is seeded by the particle's
/// id, not by the frame).
#[test]
fn noise_of_still_water_does_not_flicker() {
    let gpu = gpu();
    let r = 0.1f32;
    let v = view([0.4, 2.2, 2.6], [0.0, 0.0, 0.0], 96, 64, 40.0);
    let mut s = settings(r);
    s.noise.enabled = true;
    let p = meniscus::scene::Particles { positions: noise_slab(10, r), ..Default::default() };
    let mut tracker = meniscus::motion::MotionTracker::new(25.0);
    let mut rr = Renderer::new(&gpu).unwrap();
    let mut frames = vec![];
    for _ in 0..3 {
        let motion = tracker.next(&p);
        assert!(motion.iter().all(|m| m.accel == 0.0));
        rr.upload(meniscus::renderer::Upload::Scene {
            particles: &p,
            settings: &s,
            motion: Some(&motion),
            ahead: None,
        })
        .unwrap();
        rr.render(&v, &s).unwrap();
        let depth = read_f32(&gpu, rr.state().smoothed_depth().unwrap()).unwrap();
        frames.push((
            noise_n(&gpu, rr.state().effects().get::<NoiseEffect>().unwrap().images().unwrap(), &depth),
            rr.state().read_final().unwrap(),
        ));
    }
    assert!(frames[0].0.iter().any(|x| *x != 0.0), "no noise at all");
    for k in 1..3 {
        assert!(frames[k].0 == frames[0].0, "frame {k}: the noise image changed");
        assert!(frames[k].1 == frames[0].1, "frame {k}: the picture changed");
    }
    assert_clean(&gpu);
}

/// Every image a frame accumulates into is cleared first (the compute clears of the splat's depth and tiles, the
/// thickness and the noise accumulators): a renderer that drew other particles the frame before draws the same
/// picture, noise image and depth as a new renderer.
#[test]
fn a_frame_keeps_nothing_of_the_frame_before() {
    let gpu = gpu();
    let r = 0.1f32;
    let v = view([0.4, 2.2, 2.6], [0.0, 0.0, 0.0], 96, 64, 40.0);
    let mut s = settings(r);
    s.noise.enabled = true;
    let a = meniscus::scene::Particles { positions: noise_slab(10, r), ..Default::default() };
    // B: a smaller slab, moved: pixels A covered are empty in B.
    let b_pos: Vec<[f32; 3]> = noise_slab(6, r).iter().map(|p| [p[0] + 0.35, p[1] - 0.1, p[2] + 0.2]).collect();
    let b = meniscus::scene::Particles { positions: b_pos, ..Default::default() };
    let frame = |rr: &mut Renderer| {
        rr.upload(meniscus::renderer::Upload::scene(&b, &s)).unwrap();
        rr.render(&v, &s).unwrap();
        let depth = read_f32(&gpu, rr.state().smoothed_depth().unwrap()).unwrap();
        let noise = noise_n(&gpu, rr.state().effects().get::<NoiseEffect>().unwrap().images().unwrap(), &depth);
        (rr.state().read_final().unwrap(), noise, depth)
    };
    let mut used = Renderer::new(&gpu).unwrap();
    used.upload(meniscus::renderer::Upload::scene(&a, &s)).unwrap();
    used.render(&v, &s).unwrap();
    let (img, noise, depth) = frame(&mut used);
    let (img0, noise0, depth0) = frame(&mut Renderer::new(&gpu).unwrap());
    assert!(depth0.iter().any(|d| d.is_finite()) && noise0.iter().any(|x| *x != 0.0), "too little to test");
    assert!(depth == depth0, "the depth kept something of the frame before");
    assert!(noise == noise0, "the noise image kept something of the frame before");
    assert!(img == img0, "the picture kept something of the frame before");
    assert_clean(&gpu);
}

/// A sequence's frames move the fluid's box: the iso surface keeps its grid's buffers (made with room to spare)
/// while they hold the new frame's grid, so the frame neither reallocates them nor waits for the GPU first; the
/// particles are sorted into the new shape, and the depth equals a new renderer's bit for bit.
#[test]
fn the_iso_grid_is_kept_when_the_box_moves() {
    let gpu = gpu();
    let r = 0.1f32;
    let v = view([0.4, 2.2, 2.6], [0.0, 0.0, 0.0], 96, 64, 40.0);
    let mut s = settings(r);
    s.surface = meniscus::settings::Surface::Iso;
    let a = meniscus::scene::Particles { positions: noise_slab(10, r), ..Default::default() };
    // B: a smaller slab, moved (its grid has fewer cells, at another origin).
    let b_pos: Vec<[f32; 3]> = noise_slab(8, r).iter().map(|p| [p[0] + 0.3, p[1] - 0.1, p[2] + 0.2]).collect();
    let b = meniscus::scene::Particles { positions: b_pos, ..Default::default() };
    let grid = |rr: &Renderer| {
        let g = rr
            .state()
            .surfaces()
            .technique::<meniscus::surface::iso::IsoSurface>()
            .and_then(|i| i.grid())
            .expect("the iso grid");
        let g = g.gpu.as_ref().expect("built on the GPU");
        (g.order.raw, g.shape.origin_cell.map(f32::to_bits), g.shape.dims)
    };
    let frame = |rr: &mut Renderer| {
        rr.upload(meniscus::renderer::Upload::scene(&b, &s)).unwrap();
        rr.render(&v, &s).unwrap();
        read_f32(&gpu, rr.state().smoothed_depth().unwrap()).unwrap()
    };
    let mut used = Renderer::new(&gpu).unwrap();
    used.upload(meniscus::renderer::Upload::scene(&a, &s)).unwrap();
    used.render(&v, &s).unwrap();
    let before = grid(&used);
    let depth = frame(&mut used);
    let after = grid(&used);
    assert!(after.0 == before.0, "the grid's buffers were reallocated");
    assert!(after.1 != before.1 && after.2 != before.2, "the grid kept the first box's shape");
    let depth0 = frame(&mut Renderer::new(&gpu).unwrap());
    assert!(depth0.iter().filter(|d| d.is_finite()).count() > 500, "too little to test");
    assert!(depth == depth0, "the depth differs from a new renderer's");
    assert_clean(&gpu);
}

/// The `diffuse` pass against its CPU reference (`passes::diffuse::reference`): foam riding a slab's surface,
/// spray above it (some moving: streaks), bubbles under it (attenuated by the water above them), and one fluid
/// particle marked isolated (the patent's low-density particle, drawn the same way). The accumulators equal the
/// reference's fixed-point sums up to the float rounding of single terms.
#[test]
fn diffuse_matches_cpu_reference() {
    use meniscus::diffuse::{Kind, Particle};
    use meniscus::passes::diffuse::{encode, reference, Push, UNITS};
    let gpu = gpu();
    let (w, h) = (96usize, 64usize);
    let r = 0.1f32;
    let v = view([0.4, 2.2, 2.6], [0.0, 0.0, 0.0], w as u32, h as u32, 40.0);
    let mut s = settings(r);
    s.filter.method = Filter::None;
    s.diffuse.shutter = 0.05;
    let mut pos = noise_slab(10, r);
    let marked = pos.len();
    pos.push([0.3, 0.6, 0.2]);
    let mut marks = vec![false; pos.len()];
    marks[marked] = true;
    let mut diffuse = vec![];
    for i in 0..6 {
        for k in 0..6 {
            let (x, z) = (-0.6 + 0.24 * i as f32, -0.6 + 0.24 * k as f32);
            let kind = [Kind::Foam, Kind::Spray, Kind::Bubble][(i + k) % 3];
            let (y, vel) = match kind {
                Kind::Foam => (0.5 * r, glam::Vec3::new(0.3, 0.0, 0.0)),
                Kind::Spray => (0.3 + 0.05 * k as f32, glam::Vec3::new(2.0 * (i % 2) as f32, 1.0, 0.0)),
                Kind::Bubble => (-4.0 * r, glam::Vec3::ZERO),
            };
            let id = diffuse.len() as u32;
            let lifetime = 0.1 + 0.15 * id as f32;
            let age = 0.01 * id as f32;
            let position = glam::Vec3::new(x, y, z);
            diffuse.push(Particle { id, source: id, kind, position, velocity: vel, lifetime, age });
        }
    }
    let mut rr = Renderer::new(&gpu).unwrap();
    rr.upload(meniscus::renderer::Upload::Points {
        positions: &pos,
        radii: None,
        isolated: Some(&marks),
        motion: None,
    })
    .unwrap();
    rr.upload(meniscus::renderer::Upload::Diffuse { particles: &diffuse, settings: &s }).unwrap();
    rr.render(&v, &s).unwrap();
    let t = rr.state().targets().unwrap();
    let words = |img| read_u32(&gpu, img).unwrap();
    let own = rr.state().effects().get::<DiffuseEffect>().and_then(|d| d.images()).expect("the diffuse pass's images");
    let (white, bubbles) = (words(&own.white), words(&own.bubbles));
    let depth = read_f32(&gpu, rr.state().smoothed_depth().unwrap()).unwrap();
    let scene_depth = read_f32(&gpu, &t.scene_depth).unwrap();
    let m = v.camera.view();
    let d = &s.diffuse;
    let mut boards: Vec<reference::Billboard> = diffuse
        .iter()
        .map(|p| {
            let [a, b] = encode(p, d, r);
            let (x, vel) = (glam::Vec3::new(a[0], a[1], a[2]), glam::Vec3::new(b[0], b[1], b[2]));
            let end = |sign: f32| m.transform_point3(x + sign * 0.5 * d.shutter * vel).to_array();
            reference::Billboard {
                c0: end(-1.0),
                c1: end(1.0),
                radius: a[3],
                bubble: b[3].floor() == 2.0,
                fade: b[3] - b[3].floor(),
            }
        })
        .collect();
    let c = m.transform_point3(glam::Vec3::from(pos[marked])).to_array();
    boards.push(reference::Billboard { c0: c, c1: c, radius: r * d.size, bubble: false, fade: 1.0 });
    let push = Push {
        count: pos.len() as u32,
        diffuse: diffuse.len() as u32,
        isolated: 1,
        shutter: d.shutter,
        foam_depth: d.foam_depth * r,
        bubble_depth: d.bubble_depth * r,
        isolated_size: d.size,
        opacity: d.opacity,
        indirect: 0,
    };
    let f = v.camera.focal_px(h as u32);
    let (want_w, want_b) = reference::accumulate(&boards, &depth, &scene_depth, (w, h), f, v.camera.near, &push);
    for (name, got, want) in [("white", &white, &want_w), ("bubbles", &bubbles, &want_b)] {
        let covered = want.iter().filter(|x| **x > 0).count();
        let off = got.iter().zip(want.iter()).filter(|(a, b)| a.abs_diff(**b) > 4).count();
        let (sg, sw) = (got.iter().map(|x| *x as f64).sum::<f64>(), want.iter().map(|x| *x as f64).sum::<f64>());
        eprintln!("{name}: {covered} pixels, {off} differ by more than 4 units; sums {sg} vs {sw}");
        assert!(covered > 60, "{name}: too little to test ({covered} pixels)");
        // A pixel at a billboard's rim (q ≈ 1) may fall in or out by float rounding: at most 1 % of them.
        assert!(off * 100 <= covered, "{name}: {off} of {covered} pixels differ from the reference");
        assert!((sg - sw).abs() <= 0.01 * sw, "{name}: total coverage {sg} vs {sw}");
        assert!(sw / UNITS as f64 > 1.0);
    }
}

/// The frame's timestamp scopes: a frame that opens up to `timing::MAX_SCOPES` scopes has every pass timed
/// (same-named scopes summed); one that opens more reads as untimed — no passes, and the timer says how many were
/// left out — rather than as the cheaper frame its first scopes would sum to (a DFSPH frame records every
/// correction it may need, three scopes each).
#[test]
fn a_frame_with_more_scopes_than_the_timer_holds_reads_as_untimed() {
    use meniscus::timing::MAX_SCOPES;
    let gpu = gpu();
    let mut timer = meniscus::gpu::Timer::new(&gpu).unwrap();
    for (scopes, untimed) in [(7u32, 0u32), (MAX_SCOPES, 0), (MAX_SCOPES + 5, 5)] {
        gpu.one_shot(|cmd| {
            let mut ctx = FrameCtx::new(&gpu, cmd, Some(&mut timer));
            for i in 0..scopes {
                ctx.pass(["a", "b", "c"][i as usize % 3], |_| {});
            }
            Ok(())
        })
        .unwrap();
        let times = timer.read().unwrap();
        assert_eq!(timer.untimed(), untimed, "{scopes} scopes");
        let names: Vec<&str> = times.0.iter().map(|(n, _)| n.as_str()).collect();
        if untimed == 0 {
            assert_eq!(names, ["a", "b", "c"], "{scopes} scopes");
            assert!(times.0.iter().all(|(_, ms)| ms.is_finite() && *ms >= 0.0));
        } else {
            assert!(names.is_empty(), "{scopes} scopes: {names:?}");
        }
    }
    assert_clean(&gpu);
}

/// The passes count their own work only in a frame that asks (`FrameRequest::count_work`: each counting
/// shader's twin pipeline, WORK_COUNTING on): a frame that does not leaves the counts at 0 (the noise's coarsest
/// level, which its resolve reads, excepted), and both frames draw the same image bit for bit.
#[test]
fn a_frame_counts_its_work_only_when_asked() {
    let gpu = gpu();
    let (g, v) = splat_scene("wave", 20_000, 160, 90, 0.01, 1.0);
    let s = meniscus::settings::Settings::default().with(|s| {
        s.radius = g.radius;
        s.noise.enabled = true;
    });
    let mut r = Renderer::new(&gpu).unwrap();
    r.upload(meniscus::renderer::Upload::points(&g.particles.positions)).unwrap();
    let frame = |r: &mut Renderer, counted: bool| {
        if counted {
            render_counted(r, &v, &s).unwrap();
        } else {
            r.render(&v, &s).unwrap();
        }
        let work = r.state().work(&s, |_| true).unwrap();
        (work, read_image(&gpu, &r.state().targets().unwrap().final_color).unwrap())
    };
    let (plain, image) = frame(&mut r, false);
    let (counted, image_counted) = frame(&mut r, true);
    let (again, image_again) = frame(&mut r, false);
    assert!(image == image_counted && image == image_again, "counting changed the image");
    let (splat, iso, noise) = (counted.splat.unwrap(), counted.iso.unwrap(), counted.noise.unwrap());
    assert!(splat.tests > 0 && iso.samples > 0 && noise.evaluated > 0, "{counted:?}");
    for w in [&plain, &again] {
        assert_eq!((w.splat.unwrap().tests, w.iso.unwrap().samples), (0, 0), "{w:?}");
        let n = w.noise.unwrap();
        assert_eq!((n.level, n.texels, n.sprites, n.evaluated), (noise.level, 0, 0, 0), "{w:?}");
        // The queue's length is the cast's own (its second dispatch reads it), counted or not.
        assert_eq!(w.iso.unwrap().queued, iso.queued);
    }
    common::assert_clean(&gpu);
}

/// A sequence's frames with the iso surface's host analysis computed ahead (`surface::grid::analyse`, as
/// `render`'s prefetch thread does) render byte for byte as frames whose prepare computes it: the default
/// surface with its smoothed field, two frames whose boxes differ (the grid and the lattice move). An analysis
/// of other positions is not taken.
#[test]
fn an_analysis_computed_ahead_renders_the_same_frame() {
    use meniscus::renderer::Upload;
    let gpu = gpu();
    let (g, v) = splat_scene("wave", 20_000, 160, 90, 0.01, 1.0);
    let s = meniscus::settings::Settings::default().with(|s| s.radius = g.radius);
    assert!(s.iso_params().volume.is_some(), "the default surface smooths its field: the test covers the lattice");
    let mut moved = g.particles.clone();
    moved.positions.iter_mut().for_each(|p| p[1] += 0.7 * g.radius * (p[0] * 13.0).sin());
    let frames = [&g.particles, &moved];
    let mut images = vec![];
    for ahead in [false, true] {
        let mut r = Renderer::new(&gpu).unwrap();
        let mut got = vec![];
        for p in frames {
            let a = ahead.then(|| meniscus::surface::grid::analyse(&p.positions, &s).expect("the default surface's"));
            assert!(a.as_ref().is_none_or(|a| a.volume.is_some_and(|(_, bricks)| bricks > 0)));
            r.upload(Upload::Scene { particles: p, settings: &s, motion: None, ahead: a.as_ref() }).unwrap();
            assert_eq!(r.state().particles().analysis().is_some(), ahead, "the analysis was not taken");
            r.render(&v, &s).unwrap();
            got.push(read_image(&gpu, &r.state().targets().unwrap().final_color).unwrap());
        }
        images.push(got);
    }
    assert!(images[0][0] != images[0][1], "the two frames are the same: the test misses the moved lattice");
    assert!(images[0] == images[1], "the frames computed ahead differ");
    // Computed from other positions: refused.
    let mut r = Renderer::new(&gpu).unwrap();
    let other = meniscus::surface::grid::analyse(&moved.positions, &s);
    r.upload(Upload::Scene { particles: &g.particles, settings: &s, motion: None, ahead: other.as_ref() }).unwrap();
    assert!(other.is_some() && r.state().particles().analysis().is_none(), "an analysis of other positions was taken");
    // Where the prepare would not use one, none is computed.
    let spheres = meniscus::settings::Settings::default().with(|x| {
        x.radius = g.radius;
        x.surface = meniscus::settings::Surface::Spheres;
    });
    assert!(meniscus::surface::grid::analyse(&g.particles.positions, &spheres).is_none());
    assert_clean(&gpu);
}

/// The GPU's Laplacian smoothing and normals (`compute::smooth`, `mesh --gpu` with smoothing) give the CPU
/// reference's mesh (`field::smooth::smooth`, 25 iterations, with feature weights and without — the weights
/// computed on the device too): vertices within 10⁻⁴ r and
/// normals' components within 10⁻⁵ (0.0006°), on a random cloud's mesh and, when the shared data is here, the 6,859-particle dam
/// break's frame 40 at 1 r. The control: 24 iterations on the GPU are told apart from the CPU's 25.
#[test]
fn gpu_mesh_smoothing_matches_the_cpu() {
    use meniscus::field::extract::{extract, ExtractParams};
    use meniscus::field::iso::IsoGrid;
    use meniscus::field::smooth::{smooth, SmoothParams};
    let gpu = gpu();
    let gs = meniscus::compute::smooth::GpuSmooth::new(&gpu).unwrap();
    let mut seed = 99u32;
    let mut rnd = || {
        seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
        (seed >> 8) as f32 / (1u32 << 24) as f32
    };
    let mut cases: Vec<(String, Vec<[f32; 3]>, f32)> =
        vec![("random 400".into(), (0..400).map(|_| [rnd() * 0.6, rnd() * 0.3, rnd() * 0.4]).collect(), 0.05)];
    if let Some(f) = common::shared_data("splishsplash/dambreak_6859/partio/ParticleData_Fluid_40.bgeo") {
        cases.push(("dam break 6,859 f40".into(), meniscus::scene::load(&f).unwrap().positions, 0.025));
    }
    let apart = |a: &meniscus::field::extract::TriMesh, b: &meniscus::field::extract::TriMesh| {
        let d = a.vertices.iter().zip(&b.vertices).flat_map(|(x, y)| (0..3).map(move |k| (x[k] - y[k]).abs()));
        // Normals by component (an angle from acos reads 0.02° at one rounding step of a unit vector's dot).
        let n = a.normals.iter().zip(&b.normals).flat_map(|(x, y)| (0..3).map(move |k| (x[k] - y[k]).abs()));
        (d.fold(0f32, f32::max), n.fold(0f32, f32::max))
    };
    for (label, pts, r) in &cases {
        let grid = IsoGrid::build(pts, 4.0 * r);
        let inv = grid.inv_density();
        let raw = extract(&grid, &inv, &ExtractParams::new(*r, 0.6));
        assert!(raw.triangles.len() > 100, "{label}: {} triangles", raw.triangles.len());
        let p = SmoothParams::default();
        let mut cpu = raw.clone();
        for weights in [false, true] {
            let q = SmoothParams { weights, ..p };
            let mut cpu_q = raw.clone();
            smooth(&mut cpu_q, &grid, &inv, &q);
            let mut on_gpu = raw.clone();
            let times = gs.smooth(&gpu, &mut on_gpu, &grid, &inv, &q).unwrap();
            assert_eq!(on_gpu.triangles, cpu_q.triangles);
            let (d, angle) = apart(&cpu_q, &on_gpu);
            let n = raw.vertices.len();
            eprintln!("{label}, weights {weights}: {n} vertices, apart {} r, normals {angle}, GPU {times:?}", d / r);
            assert!(d <= 1e-4 * r && angle <= 1e-5, "{label}, weights {weights}: {} r, normals {angle} apart", d / r);
            cpu = cpu_q;
        }
        let mut short = raw.clone();
        gs.smooth(&gpu, &mut short, &grid, &inv, &SmoothParams { iterations: 24, ..p }).unwrap();
        let (d, _) = apart(&cpu, &short);
        assert!(d > 1e-3 * r, "{label}: the control (24 iterations) is {} r from 25", d / r);
    }
    assert_clean(&gpu);
}

/// The lattice order is computed only for a smoothed field that widens its blur by it (`--preset quality`, the
/// anisotropic kernels and `lattice_smoothing` = `smoothing` skip it), and when the settings then ask for it on
/// the same particles it is computed before the field is built: a block on an exact lattice rendered first
/// unsmoothed, then at the default, gives the depth a fresh renderer's default frame gives, bit for bit. The
/// control: with one blur for all (`lattice_smoothing` = `smoothing`) the depth differs, so an order left out
/// would be seen.
#[test]
fn the_lattice_order_follows_a_change_of_settings() {
    let gpu = gpu();
    let r = 0.05f32;
    let pts = jittered_slab(1, [12, 4, 10], [-0.6, -0.2, -0.5], r, [0.0; 3]);
    let v = view([0.6, 0.9, 1.6], [0.0, 0.0, 0.0], 128, 96, 45.0);
    let mut s = settings(r);
    s.filter.method = Filter::None;
    s.surface = meniscus::settings::Surface::Iso;
    let defaults = meniscus::surface::iso::params::Params::default();
    s.iso.smoothing = defaults.smoothing;
    s.iso.lattice_smoothing = defaults.lattice_smoothing;
    let depth = |steps: &[&meniscus::settings::Settings]| {
        let mut rd = Renderer::new(&gpu).unwrap();
        rd.upload(meniscus::renderer::Upload::points(&pts)).unwrap();
        for st in steps {
            rd.render(&v, st).unwrap();
        }
        read_f32(&gpu, &rd.state().targets().unwrap().depth).unwrap()
    };
    let fresh = depth(&[&s]);
    let unsmoothed = s.with(|q| q.iso.smoothing = 0.0);
    assert_eq!(depth(&[&unsmoothed, &s]), fresh, "the order computed when the settings came to need it");
    let one_blur = s.with(|q| q.iso.lattice_smoothing = q.iso.smoothing);
    let differ = depth(&[&one_blur]).iter().zip(&fresh).filter(|(a, b)| a != b).count();
    assert!(differ > 100, "the control: one blur for all changes {differ} pixels");
    assert_clean(&gpu);
}
