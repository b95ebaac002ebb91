//! Moving objects as the walls draw them: the room's block made movable and put in the sun
//! patch. Its sun shadow on the floor is exact wherever it goes (umbra dark, lit floor as
//! without it), the light field's layout never sees it, and the walls' pixels see it
//! where it stands.

use std::path::Path;
use std::sync::Arc;

use glam::{Quat, Vec3};
use holocave_scene::{LoadOptions, Placement, Ray, Scene};
use holocave_vlf::{DirectPoint, PixelDirect, Settings, Visibility};

/// The room with its block movable, and its lamp too: a moving object's emission lights
/// nothing, so with the lamp put away the sun is the only light.
fn room_with_movable_block() -> Arc<Scene> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/room.gltf");
    let opts = LoadOptions::with_objects(&["block", "lamp"]);
    let scene = Scene::load(&path, &opts).expect("the room loads");
    assert!(
        scene.lights.is_empty(),
        "the room's lamp is its emissive mesh only"
    );
    Arc::new(scene)
}

/// Far outside the room: where an object shadows nothing.
fn away() -> Placement {
    Placement::new(Vec3::splat(1000.0), Quat::IDENTITY)
}

/// The block at `at`, the lamp away.
fn block_at(at: Placement) -> [Placement; 2] {
    [at, Placement::new(Vec3::splat(-1000.0), Quat::IDENTITY)]
}

/// Whether the ray from `p` along `d` meets the block's box placed at `at` (the slab test
/// in the block's own frame: the box is the block, a cuboid).
fn meets_box(scene: &Scene, at: &Placement, p: Vec3, d: Vec3) -> bool {
    let (lo, hi) = scene.objects()[0].local_bounds();
    let (o, d) = (at.to_local_point(p), at.to_local_dir(d));
    let (mut near, mut far) = (0.0f32, f32::INFINITY);
    for a in 0..3 {
        let (t0, t1) = ((lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
        near = near.max(t0.min(t1));
        far = far.min(t0.max(t1));
    }
    near <= far
}

/// The floor points of a grid that the sun reaches with the block away, each with its
/// point as a pixel looking straight down would find it.
fn sunlit_floor(vis: &Visibility, direct: &PixelDirect) -> Vec<DirectPoint> {
    let mut lit = Vec::new();
    for i in 0..60 {
        for j in 0..60 {
            let at = Vec3::new(-2.4 + i as f32 * 0.08, 0.5, -2.4 + j as f32 * 0.08);
            let (_, point) = vis.lookup_and_point(Ray::new(at, Vec3::NEG_Y));
            let Some(p) = point else { continue };
            if p.normal.y < 0.99 || p.position.y.abs() > 1e-3 {
                continue;
            }
            let e = vis.with_placed(|s| direct.estimate(s, &p, 7, 0));
            if e.radiance.max_element() > 0.0 {
                lit.push(p);
            }
        }
    }
    lit
}

/// The block hung in the sun between the sun and the patch, three ways, casts its exact
/// shadow: where the whole sun disc is behind the block (its centre and four rim
/// directions all meet the box) the floor is dark and the estimate says an object did
/// it; where none of the disc is, the floor gets exactly what it gets with the block
/// away (the same sample of the same sun); and the shadow moves with the block.
#[test]
fn the_blocks_sun_shadow_is_exact_wherever_it_goes() {
    let scene = room_with_movable_block();
    let sun = scene.daylight.sun.clone().expect("the room has a sun");
    let vis = Visibility::of(scene.clone(), &Settings::default());
    let direct = PixelDirect::new(scene.clone());
    vis.place_objects(&block_at(away()));
    let lit = sunlit_floor(&vis, &direct);
    assert!(lit.len() > 100, "only {} sunlit floor points", lit.len());
    let unshadowed: Vec<Vec3> = lit
        .iter()
        .map(|p| vis.with_placed(|s| direct.estimate(s, p, 7, 0)).radiance)
        .collect();
    let s = sun.direction.normalize();
    let (u, v) = (
        s.any_orthonormal_vector(),
        s.any_orthonormal_vector().cross(s),
    );
    let rim = [
        s,
        s + u * sun.angular_radius,
        s - u * sun.angular_radius,
        s + v * sun.angular_radius,
        s - v * sun.angular_radius,
    ];
    let target = lit[lit.len() / 2].position;
    let mut shadows = Vec::new();
    for (k, (lift, turn)) in [(0.5f32, 0.0f32), (0.8, 0.6), (0.6, -1.1)]
        .into_iter()
        .enumerate()
    {
        let (lo, hi) = scene.objects()[0].local_bounds();
        let rotation = Quat::from_rotation_y(turn) * Quat::from_rotation_x(0.3 * k as f32);
        let centre = target + s * lift + Vec3::X * 0.15 * k as f32;
        let at = Placement::new(centre - rotation * (0.5 * (lo + hi)), rotation);
        vis.place_objects(&block_at(at));
        let (mut umbra, mut clear) = (0, 0);
        let mut shadow = Vec::new();
        for (p, free) in lit.iter().zip(&unshadowed) {
            let hits = rim
                .iter()
                .filter(|d| meets_box(&scene, &at, p.position, d.normalize()))
                .count();
            let e = vis.with_placed(|sc| direct.estimate(sc, p, 7, 0));
            if hits == rim.len() {
                umbra += 1;
                shadow.push(p.position);
                assert!(
                    e.radiance == Vec3::ZERO && e.object_shadow,
                    "placement {k}: {} lies in the block's umbra, estimate {e:?}",
                    p.position
                );
            } else if hits == 0 {
                clear += 1;
                assert!(
                    e.radiance == *free && !e.object_shadow,
                    "placement {k}: {} is clear of the block: {e:?} against {free}",
                    p.position
                );
            }
        }
        assert!(
            umbra > 5 && clear > 50,
            "placement {k}: {umbra} in umbra, {clear} clear"
        );
        shadows.push(shadow);
    }
    assert_ne!(shadows[0], shadows[1], "the shadow moved with the block");
}

/// The light field is laid out on the static scene only: no element belongs to the block,
/// and the static queries never meet it, while the walls' pixels do.
#[test]
fn the_light_field_never_sees_the_block_and_the_walls_do() {
    let scene = room_with_movable_block();
    let vis = Visibility::of(scene.clone(), &Settings::default());
    assert_eq!(vis.elements().triangles.len(), scene.triangle_count());
    let rest = scene.rest_placements()[0];
    vis.place_objects(&block_at(rest));
    let (lo, hi) = scene.objects()[0].local_bounds();
    let centre = rest.to_world_point(0.5 * (lo + hi));
    let eye = centre + Vec3::new(-1.5, 0.6, 1.2);
    let ray = Ray::new(eye, (centre - eye).normalize());
    let placed_hit = vis
        .with_placed(|s| s.closest_hit(&ray, f32::INFINITY))
        .expect("a hit");
    assert!(vis.with_placed(|s| s.object_of(placed_hit.triangle)) == Some(0));
    let static_hit = scene
        .closest_hit(&ray, f32::INFINITY)
        .expect("the wall behind");
    assert!(static_hit.t > placed_hit.t && (static_hit.triangle as usize) < scene.triangle_count());
    // Drawn where it stands: the lookup of that ray is the block's (no element; the
    // cache's samples count only from points on the block), and away it is the wall's
    // again.
    let (l, _) = vis.lookup_and_point(ray);
    assert!(l.base == u32::MAX && l.object == 1, "{l:?}");
    vis.place_objects(&block_at(away()));
    let (l, _) = vis.lookup_and_point(ray);
    assert!(
        l.base != u32::MAX && l.samples == 1.0 && l.object == 0,
        "{l:?}"
    );
}

/// An object where no pixel sees it or its light — far behind the viewer, or beyond the
/// room's wall (out of every holodeck section) — changes nothing a wall shows: every
/// lookup equals the one with the object away (a chair in the next room darkens nothing
/// here, though it is within its reach through the wall).
#[test]
fn an_object_out_of_sight_changes_nothing_seen() {
    let scene = room_with_movable_block();
    let vis = Visibility::of(scene.clone(), &Settings::default());
    let wall = holocave_cave::WallView {
        eye: Vec3::new(0.0, 1.6, 0.5),
        pa: Vec3::new(-1.5, 0.0, -1.5),
        pb: Vec3::new(1.5, 0.0, -1.5),
        pc: Vec3::new(-1.5, 3.0, -1.5),
        width: 64,
        height: 48,
    };
    vis.place_objects(&block_at(away()));
    let seen = vis.pixels(&wall);
    let (lo, hi) = scene.objects()[0].local_bounds();
    let (bmin, bmax) = scene.bounds();
    for (what, centre) in [
        ("far behind the viewer", Vec3::new(0.0, 1.0, 60.0)),
        ("beyond the back wall", Vec3::new(0.0, 1.0, bmax.z + 0.6)),
        ("under the floor", Vec3::new(0.0, bmin.y - 0.6, -1.0)),
    ] {
        let at = Placement::new(centre - 0.5 * (lo + hi), Quat::IDENTITY);
        vis.place_objects(&block_at(at));
        assert!(
            vis.pixels(&wall) == seen,
            "the block {what} changed the view"
        );
    }
}
