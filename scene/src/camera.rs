//! glTF cameras, kept as named viewpoints.

use glam::{Quat, Vec3};

/// A perspective viewpoint from the glTF file.
#[derive(Clone, Debug, PartialEq)]
pub struct NamedCamera {
    pub name: String,
    pub position: Vec3,
    /// World rotation; the camera looks along its −Z with +Y up.
    pub rotation: Quat,
    /// Vertical field of view, radians.
    pub yfov: f32,
    /// Width / height, when the file gives it.
    pub aspect: Option<f32>,
}

impl NamedCamera {
    /// The screen rectangle one metre in front of the camera, as Kooima corners
    /// (lower-left, lower-right, upper-left), for an image of the given aspect.
    pub fn screen(&self, aspect: f32) -> [Vec3; 3] {
        let h = (self.yfov / 2.0).tan();
        let w = h * self.aspect.unwrap_or(aspect);
        let to_world = |x: f32, y: f32| self.position + self.rotation * Vec3::new(x, y, -1.0);
        [to_world(-w, -h), to_world(w, -h), to_world(-w, h)]
    }
}
