//! Ray sets for the GPU ray engine's tests and its bench (which includes this file by
//! path): `holocave_scene::ray_sets` through a wall view at any resolution, and the scenes
//! they are made on.
#![allow(dead_code)]

use std::path::Path;

use glam::Vec2;
use holocave_cave::{Size, WallView};
use holocave_scene::ray_sets::{RaySets, sun};
use holocave_scene::{LoadOptions, Scene};

#[path = "../../../tests/common/require.rs"]
mod require;

/// A scene of the project's `scenes/` folder.
pub fn project_scene(name: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes")
        .join(name);
    Scene::load(&path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// Sponza of the shared scenes beside the checkout, or `None` (the caller is skipped)
/// when it is absent; with `HOLOCAVE_REQUIRE_SHARED=1` (as CI sets it) its absence is a
/// failure (the project's one skip-or-fail rule, `tests/common/require.rs`).
pub fn sponza() -> Option<Scene> {
    let path = require::shared("scenes/sponza/Sponza.gltf")?;
    Some(Scene::load(&path, &LoadOptions::default()).expect("load Sponza"))
}

/// The sets of `holocave_scene::ray_sets` through `view`, primary rays through the pixel
/// centres row by row.
pub fn ray_sets(scene: &Scene, view: &WallView) -> RaySets {
    let mut primary = Vec::with_capacity(view.size.area());
    for y in 0..view.size.height {
        for x in 0..view.size.width {
            primary.push(view.ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5)));
        }
    }
    RaySets::from_primary(scene, primary, sun())
}

/// The view through `scene`'s first camera at `width` × `height`.
pub fn camera_view(scene: &Scene, width: u32, height: u32) -> WallView {
    let cam = scene.cameras.first().expect("the scene has a camera");
    WallView::through_camera(cam, Size::new(width, height))
}
