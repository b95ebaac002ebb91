//! What the render node's tests and its `pixel_tracer` bench (which includes this file by
//! path) share: the Cornell box, and the README's view of it.

use glam::Vec3;
use holocave_cave::WallView;
use holocave_scene::{LoadOptions, Scene};

/// The README's eye: in front of the box, at standing height.
pub const EYE: Vec3 = Vec3::new(0.0, 1.0, 3.4);

/// The Cornell box of `scenes/`.
pub fn cornell() -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell.gltf");
    Scene::load(&path, &LoadOptions::default()).expect("load the Cornell box")
}

/// The front wall of a CAVE framing the box (2 m × 2 m at z = 1.2), seen from `eye` at
/// `size` × `size` pixels.
pub fn front_wall(eye: Vec3, size: u32) -> WallView {
    WallView {
        eye,
        pa: Vec3::new(-1.0, 0.0, 1.2),
        pb: Vec3::new(1.0, 0.0, 1.2),
        pc: Vec3::new(-1.0, 2.0, 1.2),
        width: size,
        height: size,
    }
}
