//! Movable objects in a real scene: a chair of the breakfast room (in
//! `../shared/scenes`; skipped where absent unless `HOLOCAVE_REQUIRE_SHARED=1`).

use crate::common;

use common::{load, shared_scene};
use glam::Vec3;
use holocave_scene::{LoadOptions, ObjectSpec, Ray, Scene};

/// A triangle's longest edge over its least height.
fn sliver(p: &[Vec3; 3]) -> f32 {
    let longest = (0..3)
        .map(|i| p[i].distance(p[(i + 1) % 3]))
        .fold(0.0, f32::max);
    let area2 = (p[1] - p[0]).cross(p[2] - p[0]).length();
    longest * longest / area2
}

#[test]
fn a_breakfast_room_chair_moves_apart_from_the_static_scene() {
    let Some(path) = shared_scene("breakfast_room/BreakfastRoom.gltf") else {
        return;
    };
    let full = load(&path);
    let opts = LoadOptions {
        objects: vec![ObjectSpec {
            name: "chair".into(),
            nodes: vec!["Chair".into(), "ChairLegs".into()],
        }],
        ..Default::default()
    };
    let scene = Scene::load(&path, &opts).unwrap();
    let [chair] = scene.objects() else {
        panic!("{} objects", scene.objects().len())
    };
    assert_eq!(chair.name, "chair");
    assert!(chair.triangle_count() > 0);
    assert_eq!(
        scene.triangle_count() + chair.triangle_count(),
        full.triangle_count()
    );
    assert_ne!(scene.fingerprint(), full.fingerprint());

    let flat = scene.with_objects_at(&scene.rest_placements()).unwrap();
    assert_eq!(flat.triangle_count(), full.triangle_count());
    // Rays from the middle of the room all about, and at the chair: the flat scene with
    // the chair at rest and the two-level queries meet what the full scene meets. The
    // chair's vertices go through its frame and back, a few float steps (δ = 2e-6 m at
    // these coordinates, under 4 m). That moves the plane of a triangle of longest edge L
    // and least height h by up to δ (1 + 2 L / h) (the chair has slivers, L / h ~ 500),
    // and a hit along the ray by that over the cosine of the angle of incidence.
    let (lo, hi) = full.bounds();
    let centre = (lo + hi) * 0.5;
    let rest = scene.rest_placements();
    let placed = scene.placed(&rest);
    let (clo, chi) = placed.object_bounds(0);
    let n = 40;
    let mut rays = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let (theta, phi) = (
                std::f32::consts::PI * (i as f32 + 0.5) / n as f32,
                std::f32::consts::TAU * (j as f32 + 0.5) / n as f32,
            );
            let dir = Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            rays.push(Ray::new(centre, dir));
            let f = Vec3::new(
                i as f32 + 0.5,
                j as f32 + 0.5,
                ((i * 7 + j * 3) % n) as f32 + 0.5,
            );
            let target = clo + (chi - clo) * f / n as f32;
            rays.push(Ray::new(centre, (target - centre).normalize()));
        }
    }
    let (mut compared, mut on_chair) = (0, 0);
    for ray in &rays {
        let hits = [&full, &flat].map(|s| s.closest_hit(ray, f32::INFINITY));
        let c = placed.closest_hit(ray, f32::INFINITY);
        let (Some(a), Some(b), Some(c)) = (hits[0], hits[1], c) else {
            assert!(
                hits[0].is_none() && hits[1].is_none() && c.is_none(),
                "{ray:?}"
            );
            continue;
        };
        let cos = ray
            .dir
            .dot(full.surface(&a).geometric_normal)
            .abs()
            .max(1e-3);
        let tol = 2e-6 * (1.0 + 2.0 * sliver(full.triangle(a.triangle))) / cos;
        assert!((a.t - b.t).abs() <= tol, "{a:?} vs {b:?} (flat)");
        assert!((a.t - c.t).abs() <= tol, "{a:?} vs {c:?} (placed)");
        let sp = placed.surface(&c).position;
        assert!(sp.distance(full.surface(&a).position) <= tol, "{ray:?}");
        compared += 1;
        on_chair += usize::from(placed.object_of(c.triangle).is_some());
    }
    assert!(compared > rays.len() / 2, "{compared}");
    assert!(on_chair >= 30, "only {on_chair} rays met the chair");
}
