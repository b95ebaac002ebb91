//! The one view type: an eye and a screen rectangle given by three corners (Kooima's
//! lower-left `pa`, lower-right `pb`, upper-left `pc`) and the image on it, as a CAVE wall
//! sees the scene. A pixel's value is the mean radiance through its patch of the screen.
//! Pixel rays go out through the screen ([`WallView::ray`]); directions come back to
//! pixels through it ([`WallView::project`]).

use glam::{DVec3, Vec2, Vec3};
use holocave_scene::{NamedCamera, Ray};

use crate::size::Size;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallView {
    pub eye: Vec3,
    pub pa: Vec3,
    pub pb: Vec3,
    pub pc: Vec3,
    /// The image's size in pixels.
    pub size: Size,
}

impl WallView {
    /// Whether `other` is an image on the same screen (corners and pixels), whatever
    /// eye it is seen from.
    pub fn same_screen(&self, other: &WallView) -> bool {
        (self.pa, self.pb, self.pc, self.size) == (other.pa, other.pb, other.pc, other.size)
    }

    /// The view of a scene's camera, its screen one metre in front of it and of the image's
    /// aspect.
    pub fn through_camera(cam: &NamedCamera, size: Size) -> Self {
        let [pa, pb, pc] = cam.screen(size.aspect());
        WallView {
            eye: cam.position,
            pa,
            pb,
            pc,
            size,
        }
    }

    /// The ray from the eye through the point `(x, y)` of the image, in pixels from the
    /// top-left corner (fractional: `(0.5, 0.5)` is the centre of the first pixel).
    pub fn ray(&self, pixel: Vec2) -> Ray {
        let s = pixel.x / self.size.width as f32;
        let t = 1.0 - pixel.y / self.size.height as f32;
        let p = self.pa + (self.pb - self.pa) * s + (self.pc - self.pa) * t;
        Ray::new(self.eye, (p - self.eye).normalize_or_zero())
    }

    /// The pixel (from the top-left corner, fractional) where the line of sight along `v`
    /// (from the eye) crosses the screen's plane, if it does so in front of the eye
    /// (computed in f64: reprojection compares positions to a fraction of a pixel).
    pub fn project(&self, v: DVec3) -> Option<(f64, f64)> {
        let (eye, pa) = (self.eye.as_dvec3(), self.pa.as_dvec3());
        let (r, u) = (self.pb.as_dvec3() - pa, self.pc.as_dvec3() - pa);
        let n = r.cross(u);
        let (num, den) = ((pa - eye).dot(n), v.dot(n));
        if den == 0.0 || !den.is_finite() {
            return None;
        }
        let t = num / den;
        if t.is_nan() || t <= 0.0 {
            return None;
        }
        let p = eye + v * t - pa;
        let s = p.dot(r) / r.length_squared();
        let q = p.dot(u) / u.length_squared();
        Some((
            s * f64::from(self.size.width),
            (1.0 - q) * f64::from(self.size.height),
        ))
    }

    /// `n` stratified, jittered rays through pixel `(x, y)`: a √n × √n grid (rounded up)
    /// of which the first `n` cells are used. `jitter` yields uniform numbers in [0, 1).
    pub fn pixel_rays(&self, x: u32, y: u32, n: u32, mut jitter: impl FnMut() -> f32) -> Vec<Ray> {
        let k = (n as f32).sqrt().ceil().max(1.0) as u32;
        (0..n)
            .map(|i| {
                let (a, b) = (i % k, i / k);
                let sx = (a as f32 + jitter()) / k as f32;
                let sy = ((b % k) as f32 + jitter()) / k as f32;
                self.ray(Vec2::new(x as f32 + sx, y as f32 + sy))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_map_to_the_screen_corners() {
        let v = WallView {
            eye: Vec3::new(0.0, 1.5, 0.0),
            pa: Vec3::new(-1.5, 0.0, -1.5),
            pb: Vec3::new(1.5, 0.0, -1.5),
            pc: Vec3::new(-1.5, 3.0, -1.5),
            size: Size::new(100, 50),
        };
        let through = |x: f32, y: f32| {
            let r = v.ray(Vec2::new(x, y));
            // Intersect with the screen plane z = −1.5.
            let t = (-1.5 - r.origin.z) / r.dir.z;
            r.at(t)
        };
        assert!((through(0.0, 50.0) - v.pa).length() < 1e-5);
        assert!((through(100.0, 50.0) - v.pb).length() < 1e-5);
        assert!((through(0.0, 0.0) - v.pc).length() < 1e-5);
    }
}
