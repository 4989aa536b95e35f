//! Camera control as pure functions on a [`Camera`] (unit-tested without a window): orbit around the target,
//! pan eye and target together, zoom towards the target, fly along the view.

use glam::Vec3;

use meniscus::scene::camera::Camera;

/// Orbit by a mouse drag of (dx, dy) pixels: yaw and pitch around the target, distance kept, pitch limited.
pub fn orbit(c: &mut Camera, dx: f32, dy: f32) {
    let d = c.eye - c.target;
    let r = d.length();
    let yaw = d.z.atan2(d.x) + dx * 0.008;
    let pitch = (d.y / r).clamp(-1.0, 1.0).asin() + dy * 0.008;
    let pitch = pitch.clamp(-1.5, 1.5);
    c.eye = c.target + r * Vec3::new(pitch.cos() * yaw.cos(), pitch.sin(), pitch.cos() * yaw.sin());
}

/// Pan by a drag of (dx, dy) pixels: eye and target move together in the view plane, scaled by the distance.
pub fn pan(c: &mut Camera, dx: f32, dy: f32) {
    let f = (c.target - c.eye).normalize();
    let right = f.cross(c.up).normalize();
    let up = right.cross(f);
    let k = (c.eye - c.target).length() * 0.0015;
    let m = (-right * dx + up * dy) * k;
    c.eye += m;
    c.target += m;
}

/// Zoom by `steps` wheel steps: the distance to the target shrinks by 0.9 per step.
pub fn zoom(c: &mut Camera, steps: f32) {
    let d = c.eye - c.target;
    c.eye = c.target + d * 0.9f32.powf(steps);
}

/// Fly for `dt` seconds: `forward`, `right` and `up` in {-1, 0, 1} (W/S, D/A, E/Q), at 0.8 × the target
/// distance per second.
pub fn fly(c: &mut Camera, (forward, right, up): (f32, f32, f32), dt: f32) {
    let f = (c.target - c.eye).normalize();
    let r = f.cross(c.up).normalize();
    let v = (c.eye - c.target).length().max(1e-3) * 0.8 * dt;
    let m = (f * forward + r * right + c.up * up) * v;
    c.eye += m;
    c.target += m;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> Camera {
        Camera::parse("0,1,4:0,1,0:45").unwrap()
    }

    #[test]
    fn orbit_keeps_target_and_distance() {
        let mut c = cam();
        orbit(&mut c, 120.0, -40.0);
        assert_eq!(c.target, Vec3::new(0.0, 1.0, 0.0));
        assert!(((c.eye - c.target).length() - 4.0).abs() < 1e-4);
        assert!(c.eye.x.abs() > 0.5, "yawed: {:?}", c.eye);
        orbit(&mut c, 0.0, 10_000.0); // pitch is limited short of the pole
        assert!((c.eye - c.target).normalize().y < 1.0);
    }

    #[test]
    fn pan_moves_eye_and_target_together() {
        let mut c = cam();
        let before = c.eye - c.target;
        pan(&mut c, 50.0, 20.0);
        assert!(((c.eye - c.target) - before).length() < 1e-5);
        assert!(c.target.x < 0.0 && c.target.y > 1.0, "drag right pans the scene right: {:?}", c.target);
    }

    #[test]
    fn zoom_and_fly() {
        let mut c = cam();
        zoom(&mut c, 2.0);
        assert!(((c.eye - c.target).length() - 4.0 * 0.81).abs() < 1e-4);
        let mut c = cam();
        fly(&mut c, (1.0, 0.0, 0.0), 0.5);
        assert!((c.eye.z - (4.0 - 1.6)).abs() < 1e-4 && (c.target.z + 1.6).abs() < 1e-4, "{:?}", c.eye);
    }
}
