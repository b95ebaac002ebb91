//! Sections from free space: rooms split at doorways, each section inside its room and
//! empty of surfaces, and bad options refused.

use std::path::Path;

use glam::{Vec2, Vec3};
use holocave_holodeck::free_space::{FreeSpaceError, FreeSpaceOptions, propose_sections};
use holocave_scene::Scene;
use holocave_scene::empty_box::triangles_inside;
use holocave_scene::material::Material;
use holocave_scene::parts::{SceneParts, TriangleShading};

/// Two triangles of the rectangle `o + s·a + t·b`, facing along `a × b`.
fn quad(o: Vec3, a: Vec3, b: Vec3) -> [[Vec3; 3]; 2] {
    [[o, o + a, o + a + b], [o, o + a + b, o + b]]
}

/// An axis-aligned solid block `lo .. hi`, every face facing out.
fn block(lo: Vec3, hi: Vec3) -> Vec<[Vec3; 3]> {
    let d = hi - lo;
    let (x, y, z) = (Vec3::X * d.x, Vec3::Y * d.y, Vec3::Z * d.z);
    [
        quad(lo, z, y),
        quad(lo + x, y, z),
        quad(lo, x, z),
        quad(lo + y, z, x),
        quad(lo, y, x),
        quad(lo + z, x, y),
    ]
    .into_iter()
    .flatten()
    .collect()
}

fn scene_of(tris: Vec<[Vec3; 3]>) -> Scene {
    let parts = SceneParts {
        name: "rooms".into(),
        shading: tris
            .iter()
            .map(|_| TriangleShading {
                normals: None,
                uvs: [Vec2::ZERO; 3],
                material: 0,
            })
            .collect(),
        positions: tris,
        materials: vec![Material::default()],
        ..SceneParts::default()
    };
    Scene::from_parts(parts, Path::new("rooms")).unwrap()
}

/// A 10 × 5 m floor plan, 3 m high, closed by walls 0.2 m thick; with `door`, a wall at
/// x = 5 splits it into two rooms joined by an opening `door` metres wide.
fn rooms(door: Option<f32>) -> Scene {
    let mut t = Vec::new();
    t.extend(block(
        Vec3::new(-0.2, -0.2, -0.2),
        Vec3::new(10.2, 0.0, 5.2),
    ));
    t.extend(block(Vec3::new(-0.2, 3.0, -0.2), Vec3::new(10.2, 3.2, 5.2)));
    t.extend(block(Vec3::new(-0.2, 0.0, -0.2), Vec3::new(0.0, 3.0, 5.2)));
    t.extend(block(Vec3::new(10.0, 0.0, -0.2), Vec3::new(10.2, 3.0, 5.2)));
    t.extend(block(Vec3::new(0.0, 0.0, -0.2), Vec3::new(10.0, 3.0, 0.0)));
    t.extend(block(Vec3::new(0.0, 0.0, 5.0), Vec3::new(10.0, 3.0, 5.2)));
    if let Some(w) = door {
        let (z0, z1) = (2.5 - 0.5 * w, 2.5 + 0.5 * w);
        t.extend(block(Vec3::new(4.9, 0.0, 0.0), Vec3::new(5.1, 3.0, z0)));
        t.extend(block(Vec3::new(4.9, 0.0, z1), Vec3::new(5.1, 3.0, 5.0)));
        t.extend(block(Vec3::new(4.9, 2.2, z0), Vec3::new(5.1, 3.0, z1)));
    }
    scene_of(t)
}

#[test]
fn a_doorway_splits_two_rooms_and_each_section_is_empty_and_in_its_room() {
    let scene = rooms(Some(0.9));
    let found = propose_sections(&scene, &FreeSpaceOptions::default()).unwrap();
    assert_eq!(found.len(), 2, "{found:#?}");
    let mut sides: Vec<bool> = Vec::new();
    for r in &found {
        // An empty room: one box covers all of its free floor.
        assert_eq!(r.sections.len(), 1, "{r:?}");
        assert!(r.covered > 0.99, "{r:?}");
        let s = r.sections[0];
        assert_eq!(triangles_inside(&scene, &s), 0, "{s:?}");
        // Each room's section stays on its side of the dividing wall, spans most of its
        // 5 × 5 m floor and reaches from the floor to the ceiling.
        let left = s.hi.x <= 4.9 + 1e-9;
        assert!(left || s.lo.x >= 5.1 - 1e-9, "{s:?} straddles the wall");
        sides.push(left);
        let d = s.hi - s.lo;
        assert!(d.x > 4.0 && d.z > 4.0 && d.y > 2.8, "{s:?}");
        assert!((r.area - 4.9 * 5.0).abs() < 4.9 * 5.0 * 0.25, "{r:?}");
    }
    sides.sort();
    assert_eq!(sides, [false, true]);
}

#[test]
fn one_room_without_a_wall_and_with_an_opening_wider_than_a_doorway() {
    for door in [None, Some(3.0)] {
        let found = propose_sections(&rooms(door), &FreeSpaceOptions::default()).unwrap();
        assert_eq!(found.len(), 1, "door {door:?}: {found:#?}");
    }
}

#[test]
fn bad_options_and_scenes_without_a_floor_are_refused() {
    let scene = rooms(None);
    for (o, name) in [
        (
            FreeSpaceOptions {
                cell: 0.0,
                ..Default::default()
            },
            "cell",
        ),
        (
            FreeSpaceOptions {
                doorway: f64::NAN,
                ..Default::default()
            },
            "doorway",
        ),
        (
            FreeSpaceOptions {
                floor: Some(f64::INFINITY),
                ..Default::default()
            },
            "floor",
        ),
    ] {
        assert_eq!(
            propose_sections(&scene, &o).unwrap_err(),
            FreeSpaceError::BadOption(name)
        );
    }
    // Standing 10 m above the floor, nowhere.
    let high = FreeSpaceOptions {
        floor: Some(10.0),
        ..Default::default()
    };
    assert!(matches!(
        propose_sections(&scene, &high),
        Err(FreeSpaceError::NoRoom { .. })
    ));
    // A wall alone: nothing faces up.
    let wall = scene_of(
        block(Vec3::ZERO, Vec3::new(0.2, 3.0, 5.0))
            .into_iter()
            .filter(|t| (t[1] - t[0]).cross(t[2] - t[0]).normalize().y < 0.9)
            .collect(),
    );
    assert_eq!(
        propose_sections(&wall, &FreeSpaceOptions::default()).unwrap_err(),
        FreeSpaceError::NoFloor
    );
}

#[test]
fn a_column_in_a_room_is_walked_around_by_more_sections_none_holding_it() {
    let mut t = Vec::new();
    t.extend(block(Vec3::new(-0.2, -0.2, -0.2), Vec3::new(8.2, 0.0, 8.2)));
    t.extend(block(Vec3::new(-0.2, 3.0, -0.2), Vec3::new(8.2, 3.2, 8.2)));
    t.extend(block(Vec3::new(-0.2, 0.0, -0.2), Vec3::new(0.0, 3.0, 8.2)));
    t.extend(block(Vec3::new(8.0, 0.0, -0.2), Vec3::new(8.2, 3.0, 8.2)));
    t.extend(block(Vec3::new(0.0, 0.0, -0.2), Vec3::new(8.0, 3.0, 0.0)));
    t.extend(block(Vec3::new(0.0, 0.0, 8.0), Vec3::new(8.0, 3.0, 8.2)));
    // A column in the middle.
    t.extend(block(Vec3::new(3.7, 0.0, 3.7), Vec3::new(4.3, 3.0, 4.3)));
    let scene = scene_of(t);
    let found = propose_sections(&scene, &FreeSpaceOptions::default()).unwrap();
    assert_eq!(found.len(), 1, "{found:#?}");
    let r = &found[0];
    assert!(r.sections.len() >= 2, "{r:?}");
    for s in &r.sections {
        assert_eq!(triangles_inside(&scene, s), 0, "{s:?}");
    }
    // The boxes together cover the floor but the column's own ring of clearance.
    assert!(r.covered > 0.9, "{r:?}");
}
