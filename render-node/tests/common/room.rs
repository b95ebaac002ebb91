//! The room with punctual lights (tests of the direct light's shadow rays).

use glam::Vec3;
use holocave_scene::{LoadOptions, PunctualKind, PunctualLight, Scene};

/// The room (its sun) with a point lamp over the table, a spot and a directional light
/// added: every kind of light whose shadow rays the GPU makes.
pub fn room_with_punctual_lights() -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/room.gltf");
    let mut scene = Scene::load(&path, &LoadOptions::default()).expect("load the room");
    assert!(scene.daylight.sun.is_some(), "the room's sun");
    let light = |name: &str, kind, position: Vec3, direction: Vec3| PunctualLight {
        name: name.into(),
        kind,
        position,
        direction: direction.normalize(),
        intensity: Vec3::splat(5.0),
        range: None,
    };
    scene.lights.extend([
        light(
            "lamp",
            PunctualKind::Point,
            Vec3::new(0.3, 1.9, 0.2),
            Vec3::NEG_Y,
        ),
        light(
            "spot",
            PunctualKind::Spot {
                cos_inner: 0.9,
                cos_outer: 0.7,
            },
            Vec3::new(-1.0, 2.2, 1.0),
            Vec3::new(0.3, -1.0, -0.2),
        ),
        light(
            "moon",
            PunctualKind::Directional,
            Vec3::ZERO,
            Vec3::new(0.4, -0.8, 0.3),
        ),
    ]);
    scene
}
