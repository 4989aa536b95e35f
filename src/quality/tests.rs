//! The measures against exact values: planes and terraces, a ray-cast plane, flicker, warping, the .npy reader.
use super::*;

/// A plane z_view = −(2 + 0.3 x_view) seen by a 64×48 camera of 45°, + `bump` on every 4th column.
fn plane(bump: f32) -> DepthImage {
    let (w, h) = (64, 48);
    let f = h as f32 / (2.0 * (22.5f32).to_radians().tan());
    let mut depth = vec![f32::INFINITY; w * h];
    for y in 4..h - 4 {
        for x in 4..w - 4 {
            // Along the ray through the pixel, solve d for z = −(2 + 0.3 x).
            let u = (x as f32 + 0.5 - w as f32 / 2.0) / f;
            let d = 2.0 / (1.0 - 0.3 * u);
            depth[y * w + x] = d + if x % 4 == 0 { bump } else { 0.0 };
        }
    }
    DepthImage { width: w, height: h, depth }
}

#[test]
fn a_plane_is_its_own_reference_and_smooth() {
    let p = plane(0.0);
    let c = compare(&p, &p, 45.0, 0.01).unwrap();
    assert_eq!(c.iou, 1.0);
    assert_eq!(c.depth_median_r, Some(0.0));
    assert!(c.normal_p90_deg.unwrap() < 0.01, "{c:?}");
    // The plane's normal is (0.3, 0, 1)/|…| up to rounding.
    let n = normals_from_depth(&p, 45.0)[20 * 64 + 30];
    let want = Vec3::new(0.3, 0.0, 1.0).normalize();
    assert!(Vec3::from_array(n).angle_between(want).to_degrees() < 0.1, "{n:?}");
    let r = roughness(&normals_from_depth(&p, 45.0), 64, 48).unwrap();
    assert!(r.p90_deg < 0.05, "{r:?}");
}

#[test]
fn terraces_are_rough_and_far_from_the_reference() {
    // The control: the same plane with a row of steps every 4 pixels scores rough and off.
    let (p, t) = (plane(0.0), plane(0.01));
    let c = compare(&t, &p, 45.0, 0.01).unwrap();
    assert_eq!(c.iou, 1.0);
    assert!(c.normal_p90_deg.unwrap() > 5.0, "{c:?}");
    assert!(c.depth_p90_r.unwrap() > 0.9, "{c:?}");
    let r = roughness(&normals_from_depth(&t, 45.0), 64, 48).unwrap();
    assert!(r.p90_deg > 5.0, "{r:?}");
    // Coverage: one image empty on a side halves the IoU.
    let mut half = p.clone();
    for y in 0..48 {
        for x in 32..64 {
            half.depth[y * 64 + x] = f32::INFINITY;
        }
    }
    let c = compare(&half, &p, 45.0, 0.01).unwrap();
    assert!((c.iou - 0.5).abs() < 0.05, "{c:?}");
    assert!(compare(&DepthImage { width: 2, height: 2, depth: vec![1.0; 4] }, &p, 45.0, 0.01).is_err());
}

#[test]
fn a_mesh_plane_ray_cast_gives_the_planes_depth() {
    // Two triangles spanning z = −3 seen from the origin: every covered pixel at depth 3.
    let q = 10.0;
    let c = |x: f32, y: f32| Vec3::new(x, y, -3.0);
    let mesh = crate::scene::geometry::Geometry {
        triangles: vec![[c(-q, -q), c(q, -q), c(q, q)], [c(-q, -q), c(q, q), c(-q, q)]],
    };
    let cam = Camera { eye: Vec3::ZERO, target: Vec3::new(0.0, 0.0, -1.0), up: Vec3::Y, fovy_deg: 45.0, near: 0.01 };
    let d = mesh_depth(&mesh, &cam, 32, 24);
    assert!(d.depth.iter().all(|v| (v - 3.0).abs() < 1e-4), "{:?}", &d.depth[..4]);
    let n = normals_from_depth(&d, 45.0);
    assert!(Vec3::from_array(n[12 * 32 + 16]).angle_between(Vec3::Z).to_degrees() < 0.05);
    // Turned away, the camera sees nothing.
    let away = Camera { target: Vec3::new(0.0, 0.0, 1.0), ..cam };
    assert!(mesh_depth(&mesh, &away, 32, 24).depth.iter().all(|v| v.is_infinite()));
}

#[test]
fn warping_along_the_true_motion_cancels_it() {
    // A rippled plane z ≈ −2 in front of a camera at the origin, its ripples (normals tilting along world x)
    // moving by 0.05 per frame: warped with that velocity the change is small, unwarped and warped the wrong
    // way it is not.
    let (w, h) = (64, 48);
    let cam = Camera { eye: Vec3::ZERO, target: Vec3::new(0.0, 0.0, -1.0), up: Vec3::Y, fovy_deg: 45.0, near: 0.01 };
    let depth = DepthImage { width: w, height: h, depth: vec![2.0; w * h] };
    let f = h as f32 / (2.0 * 22.5f32.to_radians().tan());
    let frame = |shift: f32| -> Vec<[f32; 3]> {
        (0..w * h)
            .map(|i| {
                let wx = 2.0 * ((i % w) as f32 + 0.5 - w as f32 / 2.0) / f - shift;
                Vec3::new(0.3 * (wx * 10.0).sin(), 0.0, 1.0).normalize().to_array()
            })
            .collect()
    };
    let (na, nb) = (frame(0.0), frame(0.05));
    let colour = image::RgbaImage::new(w as u32, h as u32);
    let positions: Vec<[f32; 3]> =
        (0..40).flat_map(|i| (0..30).map(move |j| [-1.0 + 0.05 * i as f32, -0.75 + 0.05 * j as f32, -2.0])).collect();
    let warp = |v: f32| {
        let velocities = vec![[v, 0.0, 0.0]; positions.len()];
        let m = SurfaceMotion { positions: &positions, velocities: &velocities, dt: 1.0, camera: &cam, radius: 0.05 };
        let mut meter = FlickerMeter::default();
        meter.add(
            &Picture { colour: &colour, depth: &depth, normals: &na },
            &Picture { colour: &colour, depth: &depth, normals: &nb },
            Some(&m),
        );
        meter.result()
    };
    let (right, wrong) = (warp(0.05), warp(-0.05));
    assert!(right.normal_mean_deg > 5.0, "{right:?}");
    assert!(right.warp_mean_deg.unwrap() < 0.4 * right.normal_mean_deg, "{right:?}");
    assert!(wrong.warp_mean_deg.unwrap() > right.normal_mean_deg, "{wrong:?}");
}

#[test]
fn a_mesh_moved_with_its_flow_does_not_flicker() {
    // A sheet of vertices rising 0.5 radii a frame (along its normal), particles on it with that velocity:
    // the warped distance is ~0, the plain one the rise; with the velocity reversed the warp makes it worse.
    // (A sheet sliding within its own plane does not change the surface, and scores ~0 unwarped too.)
    let sheet = |dy: f32| -> Vec<[f32; 3]> {
        (0..60).flat_map(|i| (0..60).map(move |j| [i as f32 * 0.25, dy, j as f32 * 0.25])).collect()
    };
    let (a, b) = (sheet(0.0), sheet(0.5));
    let run = |v: f32| {
        let vel = vec![[0.0, v, 0.0]; a.len()];
        let mut m = MeshFlickerMeter::default();
        m.add(&a, &b, 1.0, Some(&FrameMotion { positions: &a, velocities: &vel, dt: 1.0 }));
        m.result()
    };
    let (right, wrong) = (run(0.5), run(-0.5));
    assert!(right.warped_mean_r.unwrap() < 0.01, "{right:?}");
    assert!((right.plain_mean_r - 0.5).abs() < 0.01, "{right:?}");
    assert!(wrong.warped_mean_r.unwrap() > right.plain_mean_r, "{wrong:?}");
    let mut still = MeshFlickerMeter::default();
    still.add(&a, &a, 1.0, None);
    let s = still.result();
    assert_eq!((s.plain_mean_r, s.warped_mean_r), (0.0, None));
}

#[test]
fn npy_round_trip_and_errors() {
    let d = std::env::temp_dir().join(format!("meniscus-quality-npy-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let p = plane(0.0);
    let f = d.join("p.npy");
    crate::output::write_npy(&f, &[p.height, p.width], &p.depth).unwrap();
    let back = read_depth_npy(&f).unwrap();
    assert_eq!((back.width, back.height), (64, 48));
    assert_eq!(
        back.depth.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        p.depth.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
    );
    let bytes = std::fs::read(&f).unwrap();
    std::fs::write(d.join("short.npy"), &bytes[..bytes.len() - 4]).unwrap();
    let e = read_depth_npy(&d.join("short.npy")).unwrap_err().to_string();
    assert!(e.contains("short.npy") && e.contains("bytes of data"), "{e}");
    std::fs::write(d.join("png.npy"), b"\x89PNG\r\n\x1a\n....").unwrap();
    assert!(read_depth_npy(&d.join("png.npy")).unwrap_err().to_string().contains("magic"));
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn flicker_is_zero_for_still_frames_and_not_for_jittered_ones() {
    let p = plane(0.0);
    let n = normals_from_depth(&p, 45.0);
    let c0 = image::RgbaImage::from_pixel(64, 48, image::Rgba([10, 80, 160, 255]));
    let mut c1 = c0.clone();
    for (k, px) in c1.pixels_mut().enumerate() {
        px.0[2] = if k % 2 == 0 { 164 } else { 156 };
    }
    let (a, b) = (Picture { colour: &c0, depth: &p, normals: &n }, Picture { colour: &c1, depth: &p, normals: &n });
    let mut still = FlickerMeter::default();
    still.add(&a, &a, None);
    let s = still.result();
    assert_eq!((s.colour_mean, s.normal_p90_deg, s.warp_mean_deg), (0.0, 0.0, None));
    let mut jitter = FlickerMeter::default();
    jitter.add(&a, &b, None);
    let j = jitter.result();
    assert!((j.colour_mean - 4.0 / 3.0).abs() < 1e-4 && j.colour_p99 == 4.0, "{j:?}");
}
