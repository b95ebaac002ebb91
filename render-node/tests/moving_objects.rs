//! A moving object in the render cache (the render cache paper's §4): the room's block,
//! made movable, stands in the sun and casts its shadow on the floor; gather samples (which
//! see it) fill the cache, dark in the shadow. When the block is carried away, the points
//! it shadowed are dropped with it, so the floor where its shadow was shows lit at once,
//! not a ghost of the shadow fading as new samples come.

use std::path::Path;
use std::sync::Arc;

use glam::{Quat, Vec3};
use holocave_cave::{Size, WallView};
use holocave_protocol::cluster::WireObject;
use holocave_render_node::{
    DisplayBuilder, EyeView, Feed, LightField, Prior, VlfBase, WallDisplay,
};
use holocave_scene::{LoadOptions, Placement, Ray, Scene};
use holocave_tracer::{TraceSettings, Tracer};
use holocave_vlf::Settings;

// Only the light field's writer is used here.
#[allow(dead_code)]
use crate::common;

const SIZE: u32 = 32;

fn room_with_movable_block() -> Arc<Scene> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/room.gltf");
    let opts = LoadOptions::with_objects(&["block", "lamp"]);
    Arc::new(Scene::load(&path, &opts).expect("the room loads"))
}

/// The room with its block movable, and a coarse light field of it written in `dir`.
fn room_and_field(dir: &Path) -> (Arc<Scene>, std::path::PathBuf) {
    let scene = room_with_movable_block();
    let path = dir.join("room.vlf");
    let settings = Settings {
        directions: 92,
        resolution: 32,
        ..Settings::default()
    };
    common::write_field(&scene, settings, &path);
    (scene, path)
}

/// The floor below the block's place in the sun, seen from above.
fn floor_view() -> EyeView {
    let wall = WallView {
        eye: Vec3::new(0.0, 1.6, 0.5),
        pa: Vec3::new(-2.0, 0.0, 2.0),
        pb: Vec3::new(2.0, 0.0, 2.0),
        pc: Vec3::new(-2.0, 0.0, -2.0),
        size: Size::new(SIZE, SIZE),
    };
    EyeView::looking_at(wall, 0.05).expect("the eye is above the floor")
}

/// A display of the floor view fed by gathers, the light field worth one sample (so the
/// cache's samples show almost alone).
fn display(scene: &Arc<Scene>, base: &Arc<VlfBase>) -> WallDisplay {
    let tracer = Arc::new(Tracer::new(scene.clone(), TraceSettings::default()));
    let mut b = DisplayBuilder::new(Size::new(SIZE, SIZE), 1, SIZE * SIZE, tracer);
    b.light_field = Some(LightField {
        base: base.clone(),
        prior: Prior::Samples(1.0),
    });
    b.gather = true;
    b.build(Feed::Inline)
        .expect("a display (lavapipe without a GPU)")
}

/// The frame state's objects: the block at `block`, the lamp away.
fn placed(block: Vec3) -> [WireObject; 2] {
    let at = |name: &str, position: Vec3| WireObject {
        name: name.into(),
        position: position.to_array(),
        orientation: Quat::IDENTITY.to_array(),
    };
    [at("block", block), at("lamp", Vec3::splat(-1000.0))]
}

fn frames(d: &mut WallDisplay, n: usize) -> Vec<f32> {
    for _ in 0..n {
        d.frame(&[floor_view()], false);
    }
    (d.cache.image(0).pixels.iter())
        .map(|p| p.x + p.y + p.z)
        .collect()
}

#[test]
fn a_carried_objects_old_shadow_shows_lit_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, path) = room_and_field(dir.path());
    let base = Arc::new(VlfBase::open(&path, scene.clone()).unwrap());

    // The block a metre up in the sun, its shadow on the floor; then far away.
    let (lo, hi) = scene.objects()[0].local_bounds();
    let up = Vec3::new(0.0, 1.0, -0.5) - 0.5 * (lo + hi);
    let away = Vec3::splat(1000.0);

    // What the floor shows lit: a new display with the block away, at its first frame;
    // and which pixels show it settled then (within a tenth of their mean over 25
    // frames): a pixel across the edge of the window's sun patch shows a sample of the
    // light over its patch of the floor at each frame, its mean only over many.
    let mut fresh = display(&scene, &base);
    fresh.place_objects(&placed(away));
    let lit = frames(&mut fresh, 1);
    let settled = frames(&mut fresh, 24);

    // Where the block's shadow falls (and the block itself, seen from above): where the
    // light field and the exact direct light alone, at the first frame, are darker with
    // it up. (Light the block takes from elsewhere, reflected from a surface it shadows,
    // also changes: such gathers are not dropped and fade as they are resampled.)
    let mut first = display(&scene, &base);
    first.place_objects(&placed(up));
    let shaded = frames(&mut first, 1);
    let shadow: Vec<usize> = (0..lit.len())
        .filter(|&i| shaded[i] < 0.5 * lit[i] && (lit[i] - settled[i]).abs() <= 0.1 * settled[i])
        .collect();
    let mut d = display(&scene, &base);
    d.place_objects(&placed(up));
    let shadowed = frames(&mut d, 24);
    assert!(
        shadow.len() >= 8,
        "the block casts a shadow on the floor: {} pixels",
        shadow.len()
    );
    d.place_objects(&placed(away));
    let after = frames(&mut d, 1);
    // Where the shadow (or the block) was, a pixel shows the light field with the exact
    // direct light, or that blended with what the cache fills in from a point up to four
    // pixels away, worth at most half a sample against the light field's one: if that
    // point were black, still 2/3 of the lit value. A stale shadow point (worth the 24
    // frames' samples) would show the shadow.
    for &i in &shadow {
        assert!(
            after[i] >= 0.6 * lit[i],
            "pixel {i}: {} where the shadow was ({} lit, {} in the shadow)",
            after[i],
            lit[i],
            shadowed[i]
        );
    }
}

/// The block a metre up in the sun at `x` along the room's width, the lamp away.
fn block_up_at(scene: &Scene, x: f32) -> Vec<Placement> {
    let (lo, hi) = scene.objects()[0].local_bounds();
    let at = Vec3::new(x, 1.0, -0.5) - 0.5 * (lo + hi);
    vec![
        Placement::new(at, Quat::IDENTITY),
        Placement::new(Vec3::splat(-1000.0), Quat::IDENTITY),
    ]
}

/// Whether the block at `placements` hides the sun from the floor point `p`.
fn sun_hidden(scene: &Scene, placements: &[Placement], p: Vec3) -> bool {
    let sun = scene.daylight.sun.as_ref().expect("the room has a sun");
    let ray = Ray::leaving(p, Vec3::Y, sun.direction);
    scene
        .placed(placements)
        .objects_occluded(&ray, f32::INFINITY)
}

/// Whether the floor point `p` is far from the block at both `placements` (3 m, about 3.5
/// of its bounding sphere's radii: the sphere takes under 0.85² / 3² · cos ≤ 0.03 of such
/// a point's hemisphere, below the 0.04 beyond which a point gathers what an object
/// changes) and out of its sun shadows (the sun's ray passes the sphere by 0.2 m or more).
fn apart(scene: &Scene, placements: [&[Placement]; 2], p: Vec3) -> bool {
    let sun = scene
        .daylight
        .sun
        .as_ref()
        .expect("the room has a sun")
        .direction;
    placements.iter().all(|at| {
        let (c, r) = scene.objects()[0].bounding_sphere(&at[0]);
        let t = (c - p).dot(sun).max(0.0);
        c.distance(p) > 3.0 && (c - p - t * sun).length() > r + 0.2
    })
}

/// A moved object changes the direct light only at the points it shadowed, shadows or
/// stands near: the running means there start again, and every other pixel's mean goes on
/// (it keeps its estimates and takes one more). Against a wall that kept every mean, the
/// floor where the block's shadow was or now is would show the old light for as many
/// frames as it had averaged; against one that restarted every mean, each move would cost
/// the whole wall's first estimates.
#[test]
fn a_moved_object_restarts_the_direct_light_only_where_it_changed_it() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, path) = room_and_field(dir.path());
    // Every pixel takes an estimate every frame: a mean's count tells whether it went on.
    let base = VlfBase::open(&path, scene.clone())
        .unwrap()
        .with_settling(None);
    let view = floor_view();
    let (from, to) = (block_up_at(&scene, 1.0), block_up_at(&scene, 1.6));
    base.place_objects(&from);
    for _ in 0..3 {
        base.lookups(0, &view);
    }
    let held = base.estimates_held(0, &view.wall).unwrap();
    base.place_objects(&to);
    base.lookups(0, &view);
    let after = base.estimates_held(0, &view.wall).unwrap();
    let (_, points) = base.pass().visibility().pixels_and_points(&view.wall);

    // Must start again: where the block's sun shadow came or went. Must go on: far from
    // the block where it was and is, and out of its sun shadows ([`apart`]).
    let apart = |p: Vec3| apart(&scene, [&from, &to], p);
    let (mut far, mut shifted) = (0, 0);
    for (i, p) in points.iter().enumerate() {
        let Some(p) = p.filter(|p| p.normal.y > 0.9 && p.position.y.abs() < 1e-3) else {
            continue;
        };
        let went_on = after[i] == held[i] + 1;
        if sun_hidden(&scene, &from, p.position) != sun_hidden(&scene, &to, p.position) {
            shifted += 1;
            assert!(
                !went_on,
                "pixel {i} at {}: the block's shadow moved over it, its mean of {} went on",
                p.position, held[i]
            );
        }
        if apart(p.position) {
            far += 1;
            assert!(
                went_on,
                "pixel {i} at {}, far from the block and its shadows: its mean of {} started again",
                p.position, held[i]
            );
        }
    }
    assert!(
        far >= 20 && shifted >= 8,
        "{far} floor pixels far from the block, {shifted} under its moved shadow"
    );
}

/// A moved object makes a wall draw anew only the pixels it changed: those whose point it
/// now hides or no longer hides, and those whose light it changed (under its sun shadow
/// before or after, or near it); a floor pixel far from it and out of its shadows is drawn
/// again from the last frame. Seen to fail against forgetting every kept pixel on a move
/// ("far from the block ... drawn anew") and against keeping every one ("the block's
/// shadow moved over it ... drawn again").
#[test]
fn a_moved_object_draws_anew_only_the_pixels_it_changed() {
    let dir = tempfile::tempdir().unwrap();
    let (scene, path) = room_and_field(dir.path());
    let base = VlfBase::open(&path, scene.clone()).unwrap();
    let view = floor_view();
    let (from, to) = (block_up_at(&scene, 1.0), block_up_at(&scene, 1.6));
    base.place_objects(&from);
    let (_, before) = base.pass().visibility().pixels_and_points(&view.wall);
    for _ in 0..3 {
        base.lookups(0, &view);
    }
    assert_eq!(
        base.take_work().traced,
        2 * view.wall.size.area(),
        "frames 1 and 2 traced"
    );
    base.place_objects(&to);
    base.lookups(0, &view);
    let anew = base
        .drawn_anew(0, &view.wall)
        .expect("the eye's last frame");
    let (_, after) = base.pass().visibility().pixels_and_points(&view.wall);

    let apart = |p: Vec3| apart(&scene, [&from, &to], p);
    let (mut far, mut shifted, mut uncovered) = (0, 0, 0);
    for (i, (b, a)) in before.iter().zip(&after).enumerate() {
        let same = match (b, a) {
            (Some(b), Some(a)) => b.triangle == a.triangle && b.position == a.position,
            (None, None) => true,
            _ => false,
        };
        if !same {
            uncovered += 1;
            assert!(
                anew[i],
                "pixel {i}: the block moved across its view, drawn again"
            );
        }
        let Some(p) = a.filter(|p| p.normal.y > 0.9 && p.position.y.abs() < 1e-3) else {
            continue;
        };
        if sun_hidden(&scene, &from, p.position) != sun_hidden(&scene, &to, p.position) {
            shifted += 1;
            assert!(
                anew[i],
                "pixel {i} at {}: the block's shadow moved over it, drawn again",
                p.position
            );
        }
        if apart(p.position) {
            far += 1;
            assert!(
                !anew[i],
                "pixel {i} at {}: far from the block and its shadows, drawn anew",
                p.position
            );
        }
    }
    assert!(
        far >= 20 && shifted >= 8 && uncovered >= 1,
        "{far} floor pixels far from the block, {shifted} under its moved shadow, \
         {uncovered} it moved across"
    );
}
