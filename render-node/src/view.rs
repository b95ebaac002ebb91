//! One eye's view of one wall: the matrix that projects points into its image and the
//! wall view that turns its pixels into rays (both in scene coordinates). The projection
//! is always the CAVE's (`holocave_cave::frustum`); this only carries it to the GPU.

use glam::{DMat4, DVec3, Mat4, Vec3};
use holocave_cave::{Frustum, FrustumFault, Wall, config::StereoMode, off_axis};
use holocave_cave::{Size, WallView};
use holocave_protocol::cluster::EyeState;

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
    /// The view of `wall` through an eye's frustum, with the room placed in the scene by
    /// `room_to_scene`, drawn at `size` pixels.
    pub fn new(frustum: &Frustum, wall: &Wall, room_to_scene: &DMat4, size: Size) -> Self {
        EyeView {
            view_proj: frustum.view_proj().as_mat4(),
            near: frustum.near as f32,
            wall: wall_view(
                wall,
                room_to_scene,
                room_to_scene.transform_point3(frustum.eye),
                size,
            ),
        }
    }

    /// The view of `wall` as a frame state sends it (matrices already made by the master,
    /// the eye in scene coordinates, the room placed by `navigation`).
    pub fn from_state(eye: &EyeState, wall: &Wall, navigation: &DMat4, size: Size) -> Self {
        EyeView {
            view_proj: (DMat4::from_cols_array(&eye.proj) * DMat4::from_cols_array(&eye.view))
                .as_mat4(),
            near: eye.near as f32,
            wall: wall_view(wall, navigation, DVec3::from_array(eye.position), size),
        }
    }

    /// The view from `wall.eye` of a wall whose corners are given directly in scene
    /// coordinates (a tool's or a test's screen, no room): the CAVE's frustum with the
    /// near plane at most `near`.
    pub fn looking_at(wall: WallView, near: f32) -> Result<Self, FrustumFault> {
        let screen = Wall::new(
            "screen",
            [wall.pa, wall.pb, wall.pc].map(Vec3::as_dvec3),
            wall.size,
            StereoMode::Mono,
            "",
        );
        let f = off_axis(
            &screen,
            wall.eye.as_dvec3(),
            f64::from(near),
            &DMat4::IDENTITY,
        )?;
        Ok(EyeView::new(&f, &screen, &DMat4::IDENTITY, wall.size))
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
            (nx * 0.5 + 0.5) * self.wall.size.width as f32,
            (0.5 - ny * 0.5) * self.wall.size.height as f32,
            c.w,
        ))
    }
}

/// The pixel rays of `wall` seen from `eye` (scene coordinates).
fn wall_view(wall: &Wall, room_to_scene: &DMat4, eye: DVec3, size: Size) -> WallView {
    let scene = |p: DVec3| room_to_scene.transform_point3(p).as_vec3();
    WallView {
        eye: eye.as_vec3(),
        pa: scene(wall.pa),
        pb: scene(wall.pb),
        pc: scene(wall.pc),
        size,
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
            size: Size::new(64, 48),
        };
        let v = EyeView::looking_at(wall, 0.05).unwrap();
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
