//! The project's own scenes in `scenes/` are exactly what the generator makes (so the
//! code that made them is kept and they can be re-made), and they load as designed.

use crate::common;

use common::{load, project_path};
use glam::Vec3;
use holocave_scene::{MaterialKind, generate};

const REGENERATE: &str = "re-make them with `holocave scene generate --out scenes` (or run this \
     test with HOLOCAVE_BLESS=1) and commit them";

#[test]
fn committed_scenes_equal_the_generator_output() {
    let dir = project_path("scenes");
    let mut expected: Vec<(String, String)> = generate::all()
        .into_iter()
        .map(|(n, t)| (n.to_string(), t))
        .collect();
    expected.extend(
        generate::daylight_files()
            .into_iter()
            .map(|(n, t)| (n.to_string(), t.to_string())),
    );
    if std::env::var_os("HOLOCAVE_BLESS").is_some() {
        // Atomically (write, then rename), so other tests never read half a file.
        for (name, text) in &expected {
            let tmp = dir.join(format!(".{name}.tmp"));
            std::fs::write(&tmp, text).unwrap();
            std::fs::rename(&tmp, dir.join(name)).unwrap();
        }
    }
    for (name, text) in &expected {
        let path = dir.join(name);
        let committed = std::fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("{}: {e}; {REGENERATE}", path.display()));
        if committed != *text {
            let line = committed
                .lines()
                .zip(text.lines())
                .position(|(a, b)| a != b)
                .unwrap_or(committed.lines().count().min(text.lines().count()));
            panic!(
                "{} differs from the generator's output (first at line {}); {REGENERATE}",
                path.display(),
                line + 1
            );
        }
    }
    // Every glTF and daylight file in scenes/ comes from the generator.
    for entry in std::fs::read_dir(&dir).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        if name.ends_with(".gltf") || name.ends_with(".glb") || name.ends_with(".toml") {
            assert!(
                expected.iter().any(|(n, _)| *n == name),
                "scenes/{name} is not made by holocave_scene::generate"
            );
        }
    }
}

#[test]
fn generator_output_is_deterministic() {
    assert_eq!(generate::all(), generate::all());
}

#[test]
fn cornell_box_is_as_designed() {
    let scene = load(&project_path("scenes/cornell.gltf"));
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let kind = |name: &str| {
        scene
            .materials
            .iter()
            .find(|m| m.name == name)
            .unwrap_or_else(|| panic!("no material {name}"))
            .kind()
    };
    for wall in ["white", "red", "green"] {
        assert_eq!(kind(wall), MaterialKind::Diffuse, "{wall}");
    }
    assert_eq!(kind("mirror"), MaterialKind::Mirror);
    assert_eq!(kind("glass"), MaterialKind::Transmissive);
    let light = scene.materials.iter().find(|m| m.name == "light").unwrap();
    assert!((light.emissive - Vec3::new(15.0, 12.75, 9.75)).length() < 1e-4);

    let (lo, hi) = scene.bounds();
    assert!((lo - Vec3::new(-1.0, 0.0, -1.0)).length() < 1e-5, "{lo}");
    assert!((hi - Vec3::new(1.0, 2.0, 1.0)).length() < 1e-5, "{hi}");
    assert_eq!(scene.cameras.len(), 1);
    assert_eq!(scene.cameras[0].name, "front");
    // The box is open towards the camera; the camera sees the back wall through it.
    let cam = &scene.cameras[0];
    let ray = holocave_scene::Ray::new(cam.position, cam.rotation * -Vec3::Z);
    let hit = scene
        .closest_hit(&ray, f32::INFINITY)
        .expect("the back wall");
    assert!((ray.at(hit.t).z + 1.0).abs() < 1e-4);
    assert!(scene.lights.is_empty() && scene.daylight.sun.is_none());
}

#[test]
fn room_picks_up_its_daylight_file() {
    let scene = load(&project_path("scenes/room.gltf"));
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let sun = scene
        .daylight
        .sun
        .as_ref()
        .expect("room.daylight.toml has a sun");
    // 25° elevation, azimuth 250° (from +Z towards +X): it shines in through the window
    // in the wall at x = −2.5, so it lies towards −X.
    assert!((sun.direction.y - 25f32.to_radians().sin()).abs() < 1e-5);
    assert!(sun.direction.x < -0.8, "{}", sun.direction);
    assert!(scene.daylight.sky.is_some());
    assert_eq!(scene.cameras[0].name, "entrance");
    // Everything is inside the room's shell (5 m × 3 m × 4 m), nothing pokes through it.
    let (lo, hi) = scene.bounds();
    assert!(
        (hi - lo - Vec3::new(5.0, 3.0, 4.0)).length() < 1e-4,
        "{lo} {hi}"
    );
    // The window is open: a ray towards the sun through its middle leaves the room.
    let through_window = holocave_scene::Ray::new(
        Vec3::new(-2.5, 1.5, 0.0) + sun.direction * -0.01,
        sun.direction,
    );
    assert!(!scene.occluded(&through_window, f32::INFINITY));
}
