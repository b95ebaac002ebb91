//! What the render node's tests and its `pixel_tracer` bench (which includes this file by
//! path) share: the Cornell box, and the README's view of it; the room with punctual
//! lights; a light field baked into a file.

use glam::Vec3;
use holocave_cave::{Size, WallView};
use holocave_scene::{LoadOptions, Scene};

/// Skip or fail without `../shared` (`tests/common/require.rs` of the checkout).
#[path = "../../../tests/common/require.rs"]
pub mod require;

/// The room with punctual lights.
#[allow(dead_code)]
pub mod room;

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
        size: Size::new(size, size),
    }
}

/// Writes `image` as `DIR/<stem>.exr` (linear) and `DIR/<stem>.png` (preview at
/// `exposure`), for looking at a test's pictures (`HOLOCAVE_TEST_OUT`).
#[allow(dead_code)]
pub fn write_image(
    dir: &std::path::Path,
    stem: &str,
    image: &holocave_tracer::film::Image,
    exposure: f32,
) {
    std::fs::create_dir_all(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    image.write_exr(&dir.join(format!("{stem}.exr"))).unwrap();
    image
        .write_png(&dir.join(format!("{stem}.png")), exposure)
        .unwrap();
}

/// Bakes `scene`'s light field with `settings` (quietly) and writes it to `path`.
#[allow(dead_code)]
pub fn write_field(scene: &Scene, settings: holocave_vlf::Settings, path: &std::path::Path) {
    let (state, _) = holocave_vlf::bake(scene, &settings, None, &|_| {}, &mut |_| Ok::<(), ()>(()))
        .expect("bake");
    holocave_vlf::VlfFile::of(scene, settings, state)
        .write(path)
        .expect("write the light field");
}
