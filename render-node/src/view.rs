//! One eye's view of one wall: the matrix that projects points into its image and the
//! wall view that turns its pixels into rays (both in scene coordinates).

use glam::{Mat4, Vec3, Vec4};
use holocave_tracer::view::WallView;

/// What the render cache needs to draw one eye.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EyeView {
    /// Scene → clip (wgpu conventions; clip `w` is the distance along the wall's normal).
    pub view_proj: Mat4,
    /// Near plane distance (points nearer than this along the normal are not drawn).
    pub near: f32,
    /// The wall and eye in scene coordinates, and the image size.
    pub wall: WallView,
}

impl EyeView {
    /// Kooima's off-axis projection for `wall` (reversed Z, infinite far plane, as in
    /// `holocave_master::frustum`). The master's matrices may be used instead: they agree.
    pub fn kooima(wall: WallView, near: f32) -> EyeView {
        let right = (wall.pb - wall.pa).normalize();
        let up = (wall.pc - wall.pa).normalize();
        let normal = right.cross(up).normalize();
        let eye = wall.eye;
        let d = (eye - wall.pa).dot(normal);
        let (va, vb, vc) = (wall.pa - eye, wall.pb - eye, wall.pc - eye);
        let (l, r) = (right.dot(va), right.dot(vb));
        let (b, t) = (up.dot(va), up.dot(vc));
        let (w, h) = (r - l, t - b);
        let proj = Mat4::from_cols(
            Vec4::new(2.0 * d / w, 0.0, 0.0, 0.0),
            Vec4::new(0.0, 2.0 * d / h, 0.0, 0.0),
            Vec4::new((r + l) / w, (t + b) / h, 0.0, -1.0),
            Vec4::new(0.0, 0.0, near, 0.0),
        );
        let basis = Mat4::from_cols(
            right.extend(0.0),
            up.extend(0.0),
            normal.extend(0.0),
            Vec4::W,
        )
        .transpose();
        let view = basis * Mat4::from_translation(-eye);
        EyeView {
            view_proj: proj * view,
            near,
            wall,
        }
    }

    pub fn eye(&self) -> Vec3 {
        self.wall.eye
    }

    /// The pixel (fractional, from the top-left) a scene point projects to, if in front.
    pub fn project(&self, p: Vec3) -> Option<(f32, f32, f32)> {
        let c = self.view_proj * p.extend(1.0);
        if c.w <= self.near {
            return None;
        }
        let (nx, ny) = (c.x / c.w, c.y / c.w);
        Some((
            (nx * 0.5 + 0.5) * self.wall.width as f32,
            (0.5 - ny * 0.5) * self.wall.height as f32,
            c.w,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;

    #[test]
    fn projection_inverts_the_pixel_rays() {
        let wall = WallView {
            eye: Vec3::new(0.3, 1.4, 0.2),
            pa: Vec3::new(-1.5, 0.0, -1.5),
            pb: Vec3::new(1.5, 0.0, -1.5),
            pc: Vec3::new(-1.5, 3.0, -1.5),
            width: 64,
            height: 48,
        };
        let v = EyeView::kooima(wall, 0.05);
        for &(x, y) in &[(0.5, 0.5), (10.25, 30.75), (63.5, 47.5), (32.0, 24.0)] {
            let r = wall.ray(Vec2::new(x, y));
            let p = r.at(2.7);
            let (px, py, depth) = v.project(p).unwrap();
            assert!(
                (px - x).abs() < 1e-3 && (py - y).abs() < 1e-3,
                "{x},{y} -> {px},{py}"
            );
            assert!((depth - 2.7 * r.dir.dot(Vec3::NEG_Z)).abs() < 1e-4);
        }
    }
}
