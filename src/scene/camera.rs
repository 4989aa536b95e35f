//! The camera: look-at + vertical field of view, parsed from and printed as `--camera EYE:TARGET[:FOVY]`,
//! and fitted automatically to particles with percentile bounds (robust to a few stray particles).

use glam::{Mat4, Vec3};

use crate::error::{Error, Result};

/// A pinhole camera in world space (right-handed, y up by default).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position (world).
    pub eye: Vec3,
    /// Point looked at (world).
    pub target: Vec3,
    /// Up direction.
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fovy_deg: f32,
    /// Near plane distance (> 0).
    pub near: f32,
}

impl Camera {
    /// World → view (glam's look_at_rh: the camera looks down −z), with [`Camera::basis_up`].
    pub fn view(&self) -> Mat4 {
        Mat4::look_at_rh(self.eye, self.target, self.basis_up())
    }

    /// The up vector of the view basis: `up`, unless the camera looks along it (straight down or up, where
    /// `up` gives no basis), then −z looking down and +z looking up (x stays to the right of the image).
    pub fn basis_up(&self) -> Vec3 {
        let f = (self.target - self.eye).normalize_or_zero();
        if f.cross(self.up.normalize_or_zero()).length() > 1e-3 {
            self.up
        } else if f.dot(self.up) < 0.0 {
            -Vec3::Z
        } else {
            Vec3::Z
        }
    }

    /// Refuse a camera that cannot render: non-finite numbers (a fit to coordinates too large for 32-bit
    /// floats), eye on the target, or a field of view outside (1°, 170°).
    pub fn check(&self) -> Result<()> {
        // Coordinates up to 1e15: their squares (distances) stay within 32-bit floats.
        let small = self.eye.abs().max_element() <= 1e15 && self.target.abs().max_element() <= 1e15;
        let finite = self.eye.is_finite()
            && self.target.is_finite()
            && self.fovy_deg.is_finite()
            && self.near.is_finite()
            && self.view().is_finite();
        if !(finite && small)
            || (self.eye - self.target).length() < 1e-6
            || !(self.fovy_deg > 1.0 && self.fovy_deg < 170.0)
        {
            return Err(Error::Invalid(format!(
                "camera {} cannot render (non-finite, eye on the target, or field of view outside 1…170°)",
                self.to_arg()
            )));
        }
        Ok(())
    }

    /// Focal length in pixels for an image `height` pixels tall: F = H / (2 tan(fovy/2)).
    pub fn focal_px(&self, height: u32) -> f32 {
        height as f32 / (2.0 * (self.fovy_deg.to_radians() * 0.5).tan())
    }

    /// A camera at `eye` looking at `target` with a vertical field of view of `fovy_deg`, checked
    /// ([`Camera::check`]).
    pub fn new(eye: Vec3, target: Vec3, fovy_deg: f32) -> Result<Camera> {
        let dist = (eye - target).length();
        let c = Camera { eye, target, up: Vec3::Y, fovy_deg, near: (dist * 1e-3).max(1e-4) };
        c.check()?;
        Ok(c)
    }

    /// Parse `ex,ey,ez:tx,ty,tz[:fovy]`.
    pub fn parse(s: &str) -> Result<Camera> {
        let err =
            || Error::Invalid(format!("bad --camera {s:?}: expected EYE:TARGET[:FOVY_DEG], e.g. 0,2.5,6:0,0.3,0:45"));
        let parts: Vec<&str> = s.split(':').collect();
        if parts.len() < 2 || parts.len() > 3 {
            return Err(err());
        }
        let v = |p: &str| -> Result<Vec3> {
            let n: Vec<f32> =
                p.split(',').map(|x| x.trim().parse::<f32>()).collect::<Result<_, _>>().map_err(|_| err())?;
            if n.len() != 3 || n.iter().any(|x| !x.is_finite()) {
                return Err(err());
            }
            Ok(Vec3::new(n[0], n[1], n[2]))
        };
        let eye = v(parts[0])?;
        let target = v(parts[1])?;
        let fovy_deg = match parts.get(2) {
            Some(f) => f.trim().parse::<f32>().map_err(|_| err())?,
            None => 45.0,
        };
        if !(fovy_deg > 1.0 && fovy_deg < 170.0) || (eye - target).length() < 1e-6 {
            return Err(err());
        }
        Camera::new(eye, target, fovy_deg).map_err(|_| err())
    }

    /// The `--camera` argument that reproduces this camera.
    pub fn to_arg(&self) -> String {
        let f = |v: Vec3| format!("{},{},{}", fmt(v.x), fmt(v.y), fmt(v.z));
        format!("{}:{}:{}", f(self.eye), f(self.target), fmt(self.fovy_deg))
    }

    /// Fit the view to the particles' 1st–99th percentile box, seen from the front (+z) and a little above.
    pub fn fit(bounds: &crate::scene::Bounds, aspect: f32) -> Camera {
        let center = (bounds.lo + bounds.hi) * 0.5;
        let radius = ((bounds.hi - bounds.lo) * 0.5).length().max(1e-3);
        let fovy_deg: f32 = 45.0;
        let half_v = fovy_deg.to_radians() * 0.5;
        let half_h = (half_v.tan() * aspect).atan();
        let half = half_v.min(half_h);
        let dist = radius / half.sin() * 1.02;
        let dir = Vec3::new(0.0, 0.55, 1.0).normalize();
        Camera { eye: center + dir * dist, target: center, up: Vec3::Y, fovy_deg, near: (dist * 1e-3).max(1e-4) }
    }
}

fn fmt(x: f32) -> String {
    let s = format!("{x:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_round_trip() {
        let c = Camera::parse("0,2.5,6:0,0.3,0:45").unwrap();
        assert_eq!(c.eye, Vec3::new(0.0, 2.5, 6.0));
        assert_eq!(Camera::parse(&c.to_arg()).unwrap(), c);
    }

    #[test]
    fn parse_rejects_garbage() {
        for s in
            ["", "1,2:3,4,5", "1,2,3", "a,b,c:1,2,3", "0,0,0:0,0,0", "0,0,1:0,0,0:400", "1e30,1e30,1e30:1e30,1e30,0"]
        {
            assert!(Camera::parse(s).is_err(), "{s}");
        }
    }

    #[test]
    fn a_top_down_view_has_a_basis() {
        for (arg, f) in [("-1,5,0:-1,0,0", -1.0), ("-1,-5,0:-1,0,0", 1.0)] {
            let c = Camera::parse(arg).unwrap();
            let m = c.view();
            assert!(m.is_finite(), "{arg}: {m}");
            // The target is straight ahead (−z in view space); world x is the image's right.
            let t = m.transform_point3(c.target);
            assert!(t.x.abs() < 1e-5 && t.y.abs() < 1e-5 && (t.z + 5.0).abs() < 1e-4, "{arg}: {t}");
            assert!((m.transform_vector3(Vec3::X).x - 1.0).abs() < 1e-5, "{arg}");
            assert_eq!(c.basis_up().z, f);
        }
        let side = Camera::parse("0,0,5:0,0,0").unwrap();
        assert_eq!(side.basis_up(), Vec3::Y);
    }

    #[test]
    fn non_finite_cameras_are_refused() {
        let huge = crate::scene::Bounds { lo: Vec3::splat(-1e30), hi: Vec3::splat(1e30) };
        assert!(Camera::fit(&huge, 1.0).check().is_err());
        assert!(Camera::parse("0,0,5:0,0,0").unwrap().check().is_ok());
    }

    #[test]
    fn focal_length() {
        let c = Camera::parse("0,0,1:0,0,0:90").unwrap();
        assert!((c.focal_px(100) - 50.0).abs() < 1e-3);
    }
}
