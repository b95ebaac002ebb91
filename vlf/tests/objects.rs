//! Moving objects as the walls draw them: the room's block made movable and put in the sun
//! patch. Its sun shadow on the floor is exact wherever it goes (umbra dark, lit floor as
//! without it), the light field's layout never sees it, and the walls' pixels see it
//! where it stands.

use std::path::Path;
use std::sync::Arc;

use glam::{Quat, Vec3};
use holocave_cave::Size;
use holocave_scene::{LoadOptions, Placement, Ray, Scene, Sun};
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

/// The cosine-weighted fraction of the sun's disc (`s`, angular radius `r`) seen from `p`
/// past the block at `at`, by a polar midpoint rule of `n × n` cells, and the share of the
/// disc's weight in cells whose corners and middle do not all agree: the rule's error is
/// at most that share (a cell the block's edge crosses is off by at most its weight).
fn disc_seen(scene: &Scene, at: &Placement, p: Vec3, s: Vec3, r: f32, n: usize) -> (f64, f64) {
    let (u, v) = (
        s.any_orthonormal_vector(),
        s.any_orthonormal_vector().cross(s),
    );
    let dir = |rho: f32, phi: f32| {
        (s * rho.cos() + (u * phi.cos() + v * phi.sin()) * rho.sin()).normalize()
    };
    let seen = |d: Vec3| !meets_box(scene, at, p, d);
    let (dr, dp) = (r / n as f32, std::f32::consts::TAU / n as f32);
    let (mut total, mut lit, mut crossed) = (0f64, 0f64, 0f64);
    for i in 0..n {
        for j in 0..n {
            let (rho, phi) = ((i as f32 + 0.5) * dr, (j as f32 + 0.5) * dp);
            let d = dir(rho, phi);
            let w = f64::from(rho.sin() * dr * dp * d.y);
            let mid = seen(d);
            let corners = [(0, 0), (1, 0), (0, 1), (1, 1)]
                .map(|(a, b)| seen(dir((i + a) as f32 * dr, (j + b) as f32 * dp)));
            total += w;
            if mid {
                lit += w;
            }
            if corners.iter().any(|&c| c != mid) {
                crossed += w;
            }
        }
    }
    (lit / total, crossed / total)
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
/// away (the same sample of the same sun); across the penumbra, after 1024 frames, the
/// share of the disc the block leaves seen (as the slit's edge test in `pixel_direct.rs`);
/// and the shadow moves with the block.
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
    let room = SunlitRoom {
        rim: sun_disc_centre_and_rim(&sun),
        scene,
        sun,
        vis,
        direct,
        lit,
        unshadowed,
    };
    let target = room.lit[room.lit.len() / 2].position;
    let mut shadows = Vec::new();
    for (k, (lift, turn)) in [(0.5f32, 0.0f32), (0.8, 0.6), (0.6, -1.1)]
        .into_iter()
        .enumerate()
    {
        let at = block_over(&room, target, k, lift, turn);
        room.vis.place_objects(&block_at(at));
        shadows.push(check_umbra_is_dark_and_clear_floor_unchanged(&room, &at, k));
        check_penumbra_gets_the_seen_share_of_the_disc(&room, &at, k);
    }
    assert_ne!(shadows[0], shadows[1], "the shadow moved with the block");
}

/// The room in the sun with its sunlit floor: what each placement of the block is
/// checked against.
struct SunlitRoom {
    scene: Arc<Scene>,
    sun: Sun,
    vis: Visibility,
    direct: PixelDirect,
    /// The sun disc's centre and four rim directions.
    rim: [Vec3; 5],
    /// The floor points the sun reaches with the block away.
    lit: Vec<DirectPoint>,
    /// What each of `lit` gets with the block away.
    unshadowed: Vec<Vec3>,
}

/// The direction to the sun disc's centre and four directions on its rim, not normalised.
fn sun_disc_centre_and_rim(sun: &Sun) -> [Vec3; 5] {
    let s = sun.direction.normalize();
    let (u, v) = (
        s.any_orthonormal_vector(),
        s.any_orthonormal_vector().cross(s),
    );
    [
        s,
        s + u * sun.angular_radius,
        s - u * sun.angular_radius,
        s + v * sun.angular_radius,
        s - v * sun.angular_radius,
    ]
}

/// The `k`th placement of the block: `lift` towards the sun above `target` (shifted
/// 0.15 k along x), turned `turn` about y and 0.3 k about x.
fn block_over(room: &SunlitRoom, target: Vec3, k: usize, lift: f32, turn: f32) -> Placement {
    let s = room.sun.direction.normalize();
    let (lo, hi) = room.scene.objects()[0].local_bounds();
    let rotation = Quat::from_rotation_y(turn) * Quat::from_rotation_x(0.3 * k as f32);
    let centre = target + s * lift + Vec3::X * 0.15 * k as f32;
    Placement::new(centre - rotation * (0.5 * (lo + hi)), rotation)
}

/// With the block placed at `at`: every sunlit point whose whole disc the block hides is
/// dark with an object's shadow, every one it hides none of gets what it got with the
/// block away, and there are enough of each. Returns the umbra's points.
fn check_umbra_is_dark_and_clear_floor_unchanged(
    room: &SunlitRoom,
    at: &Placement,
    k: usize,
) -> Vec<Vec3> {
    let (mut umbra, mut clear) = (0, 0);
    let mut shadow = Vec::new();
    for (p, free) in room.lit.iter().zip(&room.unshadowed) {
        let hits = (room.rim.iter())
            .filter(|d| meets_box(&room.scene, at, p.position, d.normalize()))
            .count();
        let e = room.vis.with_placed(|sc| room.direct.estimate(sc, p, 7, 0));
        if hits == room.rim.len() {
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
    shadow
}

/// The penumbra, across the edge between the nearest umbra and clear grid points:
/// the mean of N frames' estimates against the seen fraction of the disc times the
/// same frames' estimates with the block away. Each estimate is the disc's light
/// times a visibility of 0 or 1, so the mean of N has σ ≤ E/(2√N); the rule's error
/// is at most its crossed share, and the cosine across the disc changes the light by
/// at most tan θ_s sin r + (1 − cos r) of itself.
fn check_penumbra_gets_the_seen_share_of_the_disc(room: &SunlitRoom, at: &Placement, k: usize) {
    let frames = 1024u32;
    let (sun, s) = (&room.sun, room.sun.direction.normalize());
    let theta = s.y.acos();
    let cosine = f64::from(theta.tan() * sun.angular_radius.sin())
        + f64::from(1.0 - sun.angular_radius.cos());
    let (a, b) = nearest_umbra_and_clear_points(room, at);
    let across = penumbra_unshadowed(room, at, a, b, frames);
    room.vis.place_objects(&block_at(*at));
    let penumbra = across.len();
    let mut worst = 0f64;
    for (q, seen, crossed, point, free) in &across {
        let e = (room.vis).with_placed(|sc| room.direct.mean(sc, point, 7, 0, frames));
        let e = f64::from(e.radiance.x);
        let sigma = free / (2.0 * f64::from(frames).sqrt());
        let tolerance = 4.0 * sigma + (crossed + cosine) * free;
        worst = worst.max((e - seen * free).abs() / tolerance);
        assert!(
            (e - seen * free).abs() <= tolerance,
            "placement {k}: at {q} {seen} of the disc is seen: {e} against {} ± {tolerance}",
            seen * free
        );
    }
    eprintln!("placement {k}: {penumbra} penumbra points, worst at {worst:.2} of its bound");
    assert!(penumbra >= 5, "placement {k}: {penumbra} penumbra points");
}

/// The closest pair of sunlit points, one in the umbra of the block at `at` and one
/// clear of it.
fn nearest_umbra_and_clear_points(room: &SunlitRoom, at: &Placement) -> (Vec3, Vec3) {
    let meets = |q: Vec3, d: &Vec3| meets_box(&room.scene, at, q, d.normalize());
    let in_umbra = |q: Vec3| room.rim.iter().all(|d| meets(q, d));
    let in_clear = |q: Vec3| !room.rim.iter().any(|d| meets(q, d));
    (room.lit.iter())
        .filter(|p| in_umbra(p.position))
        .flat_map(|u| {
            (room.lit.iter())
                .filter(|c| in_clear(c.position))
                .map(move |c| (u.position, c.position))
        })
        .min_by(|x, y| (x.0 - x.1).length().total_cmp(&(y.0 - y.1).length()))
        .expect("an umbra and a clear point")
}

/// Each penumbra point on 400 steps from `a` to `b` (where the block at `at` hides part
/// of the disc), its seen share, its crossed share and the frames' estimates with the
/// block away (the block is left away).
fn penumbra_unshadowed(
    room: &SunlitRoom,
    at: &Placement,
    a: Vec3,
    b: Vec3,
    frames: u32,
) -> Vec<(Vec3, f64, f64, DirectPoint, f64)> {
    let (sun, s) = (&room.sun, room.sun.direction.normalize());
    room.vis.place_objects(&block_at(away()));
    (0..400)
        .filter_map(|step| {
            let q = a + (b - a) * ((step as f32 + 0.5) / 400.0);
            let (seen, crossed) = disc_seen(&room.scene, at, q, s, sun.angular_radius, 64);
            if seen <= 0.0 || seen >= 1.0 {
                return None;
            }
            let ray = Ray::new(q + Vec3::Y * 0.5, Vec3::NEG_Y);
            let (_, point) = room.vis.lookup_and_point(ray);
            let point = point.expect("the floor");
            let free = (room.vis).with_placed(|sc| room.direct.mean(sc, &point, 7, 0, frames));
            Some((q, seen, crossed, point, f64::from(free.radiance.x)))
        })
        .collect()
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
        size: Size::new(64, 48),
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
