//! Movable objects against the flat scene they must equal, loading, and path files.

use std::path::{Path, PathBuf};

use glam::{Quat, Vec3};
use rand::{Rng as _, SeedableRng, rngs::SmallRng};
use serde_json::{Value, json};

use super::{ObjectPaths, PlacedScene, Placement};
use crate::generate::GltfWriter;
use crate::generate::shapes::{cube, quad};
use crate::load::{LoadOptions, ObjectSpec};
use crate::ray::{Hit, Ray};
use crate::scene::{Scene, SurfacePoint};

/// A seeded generator, so every run sees the same rays and placements.
struct Rng(SmallRng);

impl Rng {
    fn new(seed: u64) -> Rng {
        Rng(SmallRng::seed_from_u64(seed))
    }

    fn next(&mut self) -> f32 {
        self.0.random()
    }

    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        self.0.random_range(lo..hi)
    }

    /// A direction uniform over the sphere.
    fn unit(&mut self) -> Vec3 {
        let (z, phi) = (
            self.range(-1.0, 1.0),
            self.range(0.0, std::f32::consts::TAU),
        );
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    /// A rotation uniform over all rotations (Shoemake's method).
    fn rotation(&mut self) -> Quat {
        let (u, a, b) = (
            self.next(),
            self.range(0.0, std::f32::consts::TAU),
            self.range(0.0, std::f32::consts::TAU),
        );
        let (s, t) = ((1.0 - u).sqrt(), u.sqrt());
        Quat::from_xyzw(s * a.sin(), s * a.cos(), t * b.sin(), t * b.cos()).normalize()
    }
}

fn spec(name: &str, nodes: &[&str]) -> ObjectSpec {
    ObjectSpec {
        name: name.into(),
        nodes: nodes.iter().map(|n| n.to_string()).collect(),
    }
}

/// Writes `text` as `name` in a fresh folder (kept alive by the returned guard).
fn write(name: &str, text: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, text).unwrap();
    (dir, path)
}

fn cornell() -> (tempfile::TempDir, PathBuf) {
    let (_, text) = crate::generate::all()
        .into_iter()
        .find(|(n, _)| *n == "cornell.gltf")
        .unwrap();
    write("cornell.gltf", &text)
}

fn load(path: &Path, objects: Vec<ObjectSpec>) -> Result<Scene, crate::SceneError> {
    Scene::load(
        path,
        &LoadOptions {
            objects,
            ..Default::default()
        },
    )
}

/// The Cornell box with its mirror box and glass sphere (smooth normals) movable.
fn cornell_with_objects() -> Scene {
    let (_dir, path) = cornell();
    load(
        &path,
        vec![
            spec("box", &["mirror box"]),
            spec("sphere", &["glass sphere"]),
        ],
    )
    .unwrap()
}

/// Two-level queries answer as the flat scene with the objects baked in.
///
/// Bound: coordinates here are below 4 m, where an f32 step is 2.4e-7 m (4.8e-7 m from
/// 4 m up); each side carries a vertex or the ray through a rotation and a translation
/// (a few roundings each), so the two surfaces lie within δ = 1e-5 m of each other, a
/// generous multiple. Along a ray meeting a surface at angle θ to its normal that moves
/// the hit by δ / cos θ, so t and the hit point must agree within that (cos θ ≥ 1e-3).
#[test]
fn two_level_queries_match_the_flat_scene() {
    let scene = cornell_with_objects();
    let static_count = scene.triangle_count() as u32;
    assert_eq!(scene.objects().len(), 2);
    let mut rng = Rng::new(33);
    let mut object_hits = 0;
    let mut rays_checked = 0;
    let mut all = Vec::new();
    for round in 0..6 {
        let placements: Vec<Placement> = if round == 0 {
            scene.rest_placements()
        } else {
            random_placements(&mut rng)
        };
        let flat = scene.with_objects_at(&placements).unwrap();
        assert_eq!(
            flat.triangle_count(),
            scene.triangle_count()
                + scene
                    .objects()
                    .iter()
                    .map(|o| o.triangle_count())
                    .sum::<usize>()
        );
        let placed = scene.placed(&placements);
        let rays = rays_through_the_box_and_at_the_objects(&mut rng, &flat, static_count);
        let batch = placed.closest_hits(&rays, f32::INFINITY);
        for (ray, from_batch) in rays.iter().zip(&batch) {
            let a = placed.closest_hit(ray, f32::INFINITY);
            let b = flat.closest_hit(ray, f32::INFINITY);
            let (Some(a), Some(b)) = (a, b) else {
                assert_eq!(
                    a.is_some(),
                    b.is_some(),
                    "hit/miss differ for {ray:?}: {a:?} vs {b:?}"
                );
                continue;
            };
            rays_checked += 1;
            let c = from_batch.expect("closest_hits misses what closest_hit hits");
            assert!((c.t - a.t).abs() <= 1e-6 * a.t.max(1.0), "{c:?} vs {a:?}");
            let (sa, tol) = check_same_surface(&placed, &flat, ray, (&a, &b), &mut all);
            if check_hit_lies_on_its_object(&scene, &placed, &a, &sa, static_count) {
                object_hits += 1;
            }
            check_same_occlusion(&placed, &flat, ray, b.t, tol);
        }
    }
    assert!(rays_checked > 10_000, "{rays_checked}");
    assert!(
        object_hits > 500,
        "too few rays met an object: {object_hits}"
    );
}

/// A random placement of each of the two objects inside the box.
fn random_placements(rng: &mut Rng) -> Vec<Placement> {
    (0..2)
        .map(|_| {
            Placement::new(
                Vec3::new(
                    rng.range(-0.6, 0.6),
                    rng.range(0.3, 1.5),
                    rng.range(-0.6, 0.6),
                ),
                rng.rotation(),
            )
        })
        .collect()
}

/// 3000 rays from random points in and before the box in random directions, and 1000
/// aimed near a corner of a random object triangle of `flat`.
fn rays_through_the_box_and_at_the_objects(
    rng: &mut Rng,
    flat: &Scene,
    static_count: u32,
) -> Vec<Ray> {
    let mut rays: Vec<Ray> = (0..3000)
        .map(|_| {
            let o = Vec3::new(
                rng.range(-0.95, 0.95),
                rng.range(0.05, 1.95),
                rng.range(-0.95, 2.5),
            );
            Ray::new(o, rng.unit())
        })
        .collect();
    // And rays at the objects' corners and edges, where culling by bounds would err.
    for _ in 0..1000 {
        let id = static_count
            + (rng.next() * (flat.triangle_count() as u32 - static_count) as f32) as u32;
        let p = flat.triangle(id.min(flat.triangle_count() as u32 - 1));
        let target = p[0] * 0.98 + p[1] * 0.01 + p[2] * 0.01;
        let o = Vec3::new(
            rng.range(-0.95, 0.95),
            rng.range(0.05, 1.95),
            rng.range(1.0, 2.5),
        );
        rays.push(Ray::new(o, (target - o).normalize()));
    }
    rays
}

/// The placed scene's hit `a` and the flat scene's `b` of `ray` are the same surface:
/// t and the point within the bound (returned with the placed scene's surface), and
/// the same triangle's material, normals and uv, or the placed one's triangle among the
/// flat scene's hits as close (`all` is scratch for those hits).
fn check_same_surface(
    placed: &PlacedScene,
    flat: &Scene,
    ray: &Ray,
    (a, b): (&Hit, &Hit),
    all: &mut Vec<Hit>,
) -> (SurfacePoint, f32) {
    let sa = placed.surface(a);
    let sb = flat.surface(b);
    let cos = ray.dir.dot(sb.geometric_normal).abs().max(1e-3);
    let tol = 1e-5 / cos;
    assert!(
        (a.t - b.t).abs() <= tol,
        "t {} vs {} (tol {tol}) for {ray:?}",
        a.t,
        b.t
    );
    assert!(sa.position.distance(sb.position) <= tol, "{sa:?} vs {sb:?}");
    // Same triangle (the flat scene keeps the ids) unless the ray meets an edge or
    // two coplanar faces (the box's rest stands on the floor): then the flat scene
    // also meets the placed scene's triangle, as close.
    if a.triangle == b.triangle {
        assert_eq!(sa.material, sb.material);
        assert!(
            sa.geometric_normal.dot(sb.geometric_normal) > 1.0 - 1e-5,
            "{sa:?} vs {sb:?}"
        );
        assert!(
            sa.shading_normal.dot(sb.shading_normal) > 1.0 - 1e-4,
            "{sa:?} vs {sb:?}"
        );
        assert!(sa.uv.distance(sb.uv) < 1e-4);
    } else {
        flat.all_hits(ray, b.t + 2.0 * tol, all);
        assert!(
            all.iter()
                .any(|h| h.triangle == a.triangle && (h.t - a.t).abs() <= tol),
            "{a:?} is not among the flat scene's hits {all:?}"
        );
    }
    (sa, tol)
}

/// A hit on a static triangle has a static id; one on an object lies in that object's
/// ids and, at `sa`, within its placed bounds. Returns whether it met an object.
fn check_hit_lies_on_its_object(
    scene: &Scene,
    placed: &PlacedScene,
    a: &Hit,
    sa: &SurfacePoint,
    static_count: u32,
) -> bool {
    match placed.object_of(a.triangle) {
        None => {
            assert!(a.triangle < static_count);
            false
        }
        Some(k) => {
            let o = &scene.objects()[k];
            assert!(
                (o.first_triangle()..o.first_triangle() + o.triangle_count() as u32)
                    .contains(&a.triangle)
            );
            let (lo, hi) = placed.object_bounds(k);
            let pad = Vec3::splat(1e-5);
            assert!(sa.position.cmpge(lo - pad).all() && sa.position.cmple(hi + pad).all());
            true
        }
    }
}

/// Occlusion short of and beyond the hit at `t` agrees between the two scenes.
fn check_same_occlusion(placed: &PlacedScene, flat: &Scene, ray: &Ray, t: f32, tol: f32) {
    if t > 2.0 * tol {
        assert!(!placed.occluded(ray, t - tol) || flat.occluded(ray, t - tol));
        assert_eq!(
            placed.occluded(ray, t - tol),
            flat.occluded(ray, t - tol),
            "{ray:?}"
        );
    }
    assert!(placed.occluded(ray, t + tol));
}

#[test]
fn the_static_scene_leaves_the_objects_out() {
    let (_dir, path) = cornell();
    let full = load(&path, vec![]).unwrap();
    let scene = cornell_with_objects();
    let moved: usize = scene.objects().iter().map(|o| o.triangle_count()).sum();
    assert_eq!(scene.triangle_count() + moved, full.triangle_count());
    assert_ne!(scene.fingerprint(), full.fingerprint());
    let flat = scene.with_objects_at(&scene.rest_placements()).unwrap();
    assert_eq!(flat.triangle_count(), full.triangle_count());
    // The box's rest: its node's rotation and translation; its scale is in the triangles.
    let rest = scene.objects()[0].rest;
    assert!(rest.translation.distance(Vec3::new(-0.4, 0.6, -0.35)) < 1e-6);
    assert!(rest.rotation.angle_between(Quat::from_rotation_y(0.35)) < 1e-5);
    let (lo, hi) = scene.objects()[0].local_bounds();
    assert!(
        (hi - lo).distance(Vec3::new(0.6, 1.2, 0.6)) < 1e-5,
        "{lo} {hi}"
    );
    assert_eq!(scene.object_index("sphere"), Some(1));
    assert_eq!(scene.object_index("chair"), None);
}

#[test]
fn transformed_scenes_carry_their_objects() {
    let scene = cornell_with_objects();
    let rest = scene.rest_placements();
    let ray = Ray::new(Vec3::new(-0.4, 0.6, 1.5), Vec3::NEG_Z);
    let before = scene
        .placed(&rest)
        .closest_hit(&ray, f32::INFINITY)
        .unwrap();
    let (scale, offset) = (2.0, Vec3::new(10.0, -3.0, 5.0));
    let moved = scene.transformed(scale, offset).unwrap();
    let rest = moved.rest_placements();
    let ray = Ray::new(ray.origin * scale + offset, ray.dir);
    let after = moved
        .placed(&rest)
        .closest_hit(&ray, f32::INFINITY)
        .unwrap();
    assert_eq!(after.triangle, before.triangle);
    assert!(
        (after.t - before.t * scale).abs() < 1e-4,
        "{after:?} {before:?}"
    );
}

#[test]
#[should_panic(expected = "one placement per movable object")]
fn placing_needs_one_placement_per_object() {
    let scene = cornell_with_objects();
    scene.placed(&[Placement::default()]);
}

#[test]
fn with_objects_at_needs_one_placement_per_object() {
    let scene = cornell_with_objects();
    let e = scene.with_objects_at(&[]).err().unwrap().to_string();
    assert!(e.contains("0 placements given for 2 objects"), "{e}");
}

/// A floor and a unit cube "crate" (scaled by 2 on x) marked movable in its extras, with
/// a camera as its child.
fn marked_scene() -> String {
    let mut w = GltfWriter::default();
    let grey = w.material(json!({ "name": "grey" }));
    let (p, n, i) = quad(Vec3::new(-2.0, 0.0, 2.0), Vec3::X * 4.0, Vec3::NEG_Z * 4.0);
    let floor = w.mesh("floor", &p, &n, &i, grey);
    w.node("floor", floor, Vec3::ZERO, Quat::IDENTITY, Vec3::ONE);
    let (p, n, i) = cube();
    let crate_mesh = w.mesh("crate", &p, &n, &i, grey);
    w.node(
        "crate",
        crate_mesh,
        Vec3::new(0.5, 0.5, 0.0),
        Quat::from_rotation_y(0.3),
        Vec3::new(2.0, 1.0, 1.0),
    );
    w.camera("on the crate", Vec3::Y, Quat::IDENTITY, 0.8);
    let mut doc: Value = serde_json::from_str(&w.finish()).unwrap();
    doc["nodes"][1]["extras"] = json!({ "holocave": { "movable": true } });
    doc["nodes"][1]["children"] = json!([2]);
    doc["scenes"][0]["nodes"] = json!([0, 1]);
    doc.to_string()
}

#[test]
fn nodes_marked_movable_in_the_file_are_objects() {
    let (_dir, path) = write("marked.gltf", &marked_scene());
    let scene = load(&path, vec![]).unwrap();
    assert_eq!(scene.triangle_count(), 2, "the floor alone is static");
    let [o] = scene.objects() else {
        panic!("{} objects", scene.objects().len())
    };
    assert_eq!(o.name, "crate");
    assert_eq!(o.triangle_count(), 12);
    assert!(o.rest.translation.distance(Vec3::new(0.5, 0.5, 0.0)) < 1e-6);
    assert!(o.rest.rotation.angle_between(Quat::from_rotation_y(0.3)) < 1e-5);
    let (lo, hi) = o.local_bounds();
    assert!(
        (hi - lo).distance(Vec3::new(2.0, 1.0, 1.0)) < 1e-5,
        "{lo} {hi}"
    );
    assert_eq!(scene.cameras.len(), 1, "the camera stays, static");
    let w: Vec<_> = scene
        .warnings
        .iter()
        .filter(|w| w.contains("under movable objects"))
        .collect();
    assert_eq!(w.len(), 1, "{:?}", scene.warnings);
    // Unmarked, the crate is static.
    let plain = marked_scene().replace("\"movable\":true", "\"movable\":false");
    let (_dir, path) = write("plain.gltf", &plain);
    let scene = load(&path, vec![]).unwrap();
    assert_eq!((scene.triangle_count(), scene.objects().len()), (14, 0));
}

#[test]
fn an_unknown_node_is_refused_by_name() {
    let (_dir, path) = cornell();
    let e = load(&path, vec![spec("chair", &["mirror box", "no such node"])])
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("no such node") && e.contains("cornell.gltf"),
        "{e}"
    );
}

#[test]
fn a_node_claimed_twice_is_refused() {
    let (_dir, path) = cornell();
    let e = load(
        &path,
        vec![
            spec("a", &["mirror box"]),
            spec("b", &["floor", "mirror box"]),
        ],
    )
    .err()
    .unwrap()
    .to_string();
    assert!(
        e.contains("claimed by two objects") && e.contains("\"a\""),
        "{e}"
    );
    // An object inside another's node.
    let (_dir, path) = write("marked.gltf", &marked_scene());
    let e = load(
        &path,
        vec![spec("camera", &["on the crate"]), spec("crate", &["crate"])],
    );
    let e = e.err().unwrap().to_string();
    assert!(e.contains("claimed by two objects"), "{e}");
}

#[test]
fn an_emissive_object_is_warned_of() {
    let (_dir, path) = cornell();
    let scene = load(&path, vec![spec("lamp", &["light"])]).unwrap();
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("\"lamp\"") && w.contains("lights nothing")),
        "{:?}",
        scene.warnings
    );
}

const PATHS: &str = "\
# a chair that slides and turns
object,time_s,tx,ty,tz,qx,qy,qz,qw

chair, 1.0, 0, 0, 0, 0, 0, 0, 1
chair, 3.0, 2, 0, 4, 0, 0.7071068, 0, 0.7071068
 lamp ,0,1,2,3,0,0,0,2
";

#[test]
fn paths_interpolate_and_clamp() {
    let paths = ObjectPaths::parse(PATHS, Path::new("moves.csv")).unwrap();
    let at = |t| paths.placement_at("chair", t).unwrap();
    assert_eq!(at(0.0), at(1.0), "before the first key: the first");
    assert_eq!(at(9.0), at(3.0), "after the last key: the last");
    assert_eq!(at(1.0).translation, Vec3::ZERO);
    let mid = at(2.0);
    assert!(mid.translation.distance(Vec3::new(1.0, 0.0, 2.0)) < 1e-6);
    assert!(
        mid.rotation
            .angle_between(Quat::from_rotation_y(std::f32::consts::FRAC_PI_4))
            < 1e-5
    );
    let quarter = at(1.5);
    assert!(quarter.translation.distance(Vec3::new(0.5, 0.0, 1.0)) < 1e-6);
    assert!(
        quarter
            .rotation
            .angle_between(Quat::from_rotation_y(std::f32::consts::FRAC_PI_8))
            < 1e-5
    );
    // Bit-identical on repeat.
    for t in [0.3, 1.7, 2.2, 2.9999] {
        let (a, b) = (at(t), at(t));
        assert_eq!(
            a.translation.to_array().map(f32::to_bits),
            b.translation.to_array().map(f32::to_bits)
        );
        assert_eq!(
            a.rotation.to_array().map(f32::to_bits),
            b.rotation.to_array().map(f32::to_bits)
        );
    }
    // A one-key path stands still; its quaternion is normalised.
    let lamp = paths.placement_at("lamp", 5.0).unwrap();
    assert_eq!(lamp.translation, Vec3::new(1.0, 2.0, 3.0));
    assert_eq!(lamp.rotation, Quat::IDENTITY);
    assert_eq!(paths.placement_at("table", 1.0), None);
}

#[test]
fn paths_place_every_object_and_are_checked_against_the_scene() {
    let scene = cornell_with_objects();
    let text = "object,time_s,tx,ty,tz,qx,qy,qz,qw\nsphere,0,0,1,0,0,0,0,1\n";
    let paths = ObjectPaths::parse(text, Path::new("p.csv")).unwrap();
    paths.check(&scene).unwrap();
    let at = paths.placements_at(&scene, 4.0);
    assert_eq!(
        at,
        vec![
            scene.objects()[0].rest,
            Placement::new(Vec3::Y, Quat::IDENTITY)
        ]
    );
    let text = "object,time_s,tx,ty,tz,qx,qy,qz,qw\ntable,0,0,1,0,0,0,0,1\n";
    let e = ObjectPaths::parse(text, Path::new("p.csv"))
        .unwrap()
        .check(&scene);
    let e = e.err().unwrap().to_string();
    assert!(e.contains("p.csv") && e.contains("\"table\""), "{e}");
}

#[test]
fn garbage_paths_are_refused_with_their_line() {
    let header = "object,time_s,tx,ty,tz,qx,qy,qz,qw";
    let row = "chair,0,0,0,0,0,0,0,1";
    let cases: [(String, &str); 8] = [
        (
            "object,time,tx,ty,tz,qx,qy,qz,qw\n".into(),
            ":1: the header",
        ),
        (
            format!("# moves\n\n{header}\nchair,0,0,0,0,0,0,1\n"),
            ":4: 8 fields",
        ),
        (
            format!("{header}\n{row}\nchair,1,0,x,0,0,0,0,1\n"),
            ":3: ty \"x\" is not a number",
        ),
        (
            format!("{header}\nchair,1,0,0,inf,0,0,0,1\n"),
            ":2: tz \"inf\" is not finite",
        ),
        (
            format!("{header}\nchair,NaN,0,0,0,0,0,0,1\n"),
            ":2: time_s \"NaN\" is not finite",
        ),
        (
            format!("{header}\nchair,0,1e39,0,0,0,0,0,1\n"),
            ":2: tx \"1e39\" is not finite",
        ),
        (
            format!("{header}\nchair,0,0,0,0,0,0,0,0\n"),
            ":2: the rotation quaternion has zero length",
        ),
        (
            format!("{header}\n{row}\nlamp,0,0,0,0,0,0,0,1\nchair,0,0,0,0,0,0,0,1\n"),
            ":4: object \"chair\" at 0 s: times must increase",
        ),
    ];
    for (text, want) in cases {
        let e = ObjectPaths::parse(&text, Path::new("moves.csv")).err();
        let e = e.unwrap_or_else(|| panic!("accepted {text:?}")).to_string();
        assert!(
            e.starts_with("moves.csv") && e.contains(want),
            "{e:?} lacks {want:?}"
        );
    }
    let e = ObjectPaths::parse("# nothing\n", Path::new("moves.csv"))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("no header"), "{e}");
}
