//! A CAVE's holodeck with the sections of a walk-through: created with the CAVE's section
//! and the rooms given (or the config's), opened again as it was, a box that is no box
//! refused.

use std::path::Path;

use glam::DVec3;
use holocave_cave::load_cave;
use holocave_scene::{LoadOptions, Scene};
use holocave_tracer::cave_holodeck::{CaveHolodeck, CaveHolodeckError};

fn room_cave() -> holocave_cave::Cave {
    let config = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/cave4-room.toml");
    load_cave(&config).unwrap()
}

fn room_scene(dir: &Path) -> (Scene, std::path::PathBuf) {
    let path = dir.join("room.gltf");
    let (_, gltf) = (holocave_scene::generate::all().into_iter())
        .find(|(name, _)| name.starts_with("room"))
        .expect("the generated room");
    std::fs::write(&path, gltf).unwrap();
    (Scene::load(&path, &LoadOptions::default()).unwrap(), path)
}

#[test]
fn a_new_file_holds_the_caves_section_then_each_room_given() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, scene_path) = room_scene(dir.path());
    let cave = room_cave();
    let rooms = [
        [DVec3::new(-2.0, 1.0, -1.5), DVec3::new(0.0, 2.5, 1.5)],
        [DVec3::new(0.5, 1.0, -1.5), DVec3::new(2.0, 2.5, 1.5)],
    ];
    let path = dir.path().join("walk.hdk");
    let made =
        CaveHolodeck::open_or_create(&path, &cave, &scene_path, Some(&scene), "test", &rooms)
            .unwrap();
    let s = made.file.sections();
    assert_eq!(s.len(), 3);
    for (section, [lo, hi]) in s[1..].iter().zip(rooms) {
        assert_eq!(section.origin(), lo);
        assert!((section.origin() + section.edges().iter().sum::<DVec3>() - hi).length() < 1e-12);
    }
    let first = s[0].origin();
    drop(made);
    // Opened again, as it was: the rooms asked for now change nothing.
    let opened =
        CaveHolodeck::open_or_create(&path, &cave, &scene_path, None, "test", &rooms[..1]).unwrap();
    assert_eq!(opened.file.sections().len(), 3);
    assert_eq!(opened.file.sections()[0].origin(), first);
}

/// Without rooms given, a new file takes the config's `[navigation] sections`; rooms given
/// take their place.
#[test]
fn the_configs_sections_are_the_rooms_unless_others_are_given() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, scene_path) = room_scene(dir.path());
    let mut cave = room_cave();
    let room = [DVec3::new(-2.0, 1.0, -1.5), DVec3::new(0.0, 2.5, 1.5)];
    cave.navigation.sections = vec![room];
    let path = dir.path().join("config.hdk");
    let made =
        CaveHolodeck::open_or_create(&path, &cave, &scene_path, Some(&scene), "test", &[]).unwrap();
    assert_eq!(made.file.sections().len(), 2);
    assert_eq!(made.file.sections()[1].origin(), room[0]);
    let given = [[DVec3::new(0.5, 1.0, -1.5), DVec3::new(2.0, 2.5, 1.5)]; 2];
    let path = dir.path().join("given.hdk");
    let made =
        CaveHolodeck::open_or_create(&path, &cave, &scene_path, Some(&scene), "test", &given)
            .unwrap();
    assert_eq!(made.file.sections().len(), 3);
    assert_eq!(made.file.sections()[1].origin(), given[0][0]);
}

#[test]
fn a_flat_box_is_refused_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, scene_path) = room_scene(dir.path());
    let cave = room_cave();
    let flat = [[DVec3::new(0.0, 1.0, 0.0), DVec3::new(1.0, 1.0, 1.0)]];
    let path = dir.path().join("flat.hdk");
    let e = CaveHolodeck::open_or_create(&path, &cave, &scene_path, Some(&scene), "test", &flat)
        .err()
        .expect("a flat section is refused");
    assert!(matches!(e, CaveHolodeckError::Section(_)), "{e}");
    assert!(e.to_string().contains("[0, 1, 0] .. [1, 1, 1]"), "{e}");
    assert!(!path.exists(), "no file is left behind");
}
