//! The light field's per-pixel visibility as a render node runs it every frame: one eye
//! ray per pixel (first hits in packets), continued through mirrors and glass, into a
//! lookup. On one thread (as each node of `holocave sim`) and on all cores, at the sim's
//! wall size and at 1024×768, on the Cornell box (mirror and glass) and the room.

use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{Quat, Vec3};
use holocave_cave::{Size, WallView};
use holocave_scene::{LoadOptions, Scene};
use holocave_vlf::{Settings, Visibility};

fn scene(name: &str) -> Arc<Scene> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes")
        .join(name);
    Arc::new(Scene::load(&path, &LoadOptions::default()).expect("scene"))
}

fn view(eye: Vec3, z: f32, width: u32, height: u32) -> WallView {
    WallView {
        eye,
        pa: Vec3::new(-1.5, 0.0, z),
        pb: Vec3::new(1.5, 0.0, z),
        pc: Vec3::new(-1.5, 3.0, z),
        size: Size::new(width, height),
    }
}

fn visibility(c: &mut Criterion) {
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a pool");
    for (name, eye, z) in [
        ("cornell.gltf", Vec3::new(0.0, 1.0, 3.4), 1.2),
        ("room.gltf", Vec3::new(0.0, 1.6, 0.5), -1.5),
    ] {
        let scene = scene(name);
        // The layout depends on the settings only through the element size.
        let vis = Visibility::of(scene.clone(), &Settings::default());
        let mut group = c.benchmark_group(format!("vlf visibility/{name}"));
        group.sample_size(10);
        group.measurement_time(Duration::from_secs(5));
        for (w, h) in [(128, 96), (1024, 768)] {
            let v = view(eye, z, w, h);
            group.bench_function(format!("{w}x{h}, one thread"), |b| {
                b.iter(|| one.install(|| vis.pixels(&v)))
            });
            group.bench_function(format!("{w}x{h}, all cores"), |b| b.iter(|| vis.pixels(&v)));
        }
        group.finish();
    }
}

/// Moving objects' cost: the room with its block and its table top (boxes of 12
/// triangles, in view) static, against the same room with both moving (each ray also
/// carried into their frames and tried against their boxes and BVHs).
fn moving_objects(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/room.gltf");
    let node = holocave_scene::ObjectSpec::node;
    let moving = LoadOptions {
        objects: vec![node("block"), node("table top")],
        ..Default::default()
    };
    let mut group = c.benchmark_group("vlf visibility/room.gltf objects");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(5));
    let v = view(Vec3::new(0.0, 1.6, 0.5), -1.5, 1024, 768);
    for (label, opts) in [("static", LoadOptions::default()), ("moving", moving)] {
        let Ok(scene) = Scene::load(&path, &opts) else {
            eprintln!("{label}: the room's nodes are not as this bench expects; skipped");
            continue;
        };
        let vis = Visibility::of(Arc::new(scene), &Settings::default());
        group.bench_function(
            format!("1024x768, all cores, block and table top {label}"),
            |b| b.iter(|| vis.pixels(&v)),
        );
    }
    group.finish();
}

/// A room's corner (floor and back wall) with a ball of `rings × segments × 2` triangles
/// (less the poles') 2 m in front of the eye, 1 m across; the ball movable or not.
fn ball_scene(dir: &Path, rings: u32, segments: u32, movable: bool) -> (Arc<Scene>, usize) {
    use holocave_scene::generate::{GltfWriter, shapes};
    use serde_json::json;
    let mut w = GltfWriter::default();
    let grey = w.material(json!({
        "name": "grey",
        "pbrMetallicRoughness": { "baseColorFactor": [0.6, 0.6, 0.6, 1.0], "metallicFactor": 0.0 }
    }));
    let (p, n, i) = shapes::quad(Vec3::new(-3.0, 0.0, 3.0), Vec3::X * 6.0, Vec3::Z * -6.0);
    let floor = w.mesh("floor", &p, &n, &i, grey);
    w.node("floor", floor, Vec3::ZERO, Quat::IDENTITY, Vec3::ONE);
    let (p, n, i) = shapes::quad(Vec3::new(-3.0, 0.0, -3.0), Vec3::X * 6.0, Vec3::Y * 3.0);
    let wall = w.mesh("wall", &p, &n, &i, grey);
    w.node("wall", wall, Vec3::ZERO, Quat::IDENTITY, Vec3::ONE);
    let (p, n, i) = shapes::sphere(rings, segments);
    let triangles = i.len() / 3;
    let ball = w.mesh("ball", &p, &n, &i, grey);
    w.node(
        "ball",
        ball,
        Vec3::new(0.0, 1.2, -1.5),
        Quat::IDENTITY,
        Vec3::splat(0.5),
    );
    let path = dir.join(format!("ball-{rings}.gltf"));
    std::fs::write(&path, w.finish()).expect("a scratch file");
    let opts = LoadOptions {
        objects: match movable {
            true => vec![holocave_scene::ObjectSpec::node("ball")],
            false => vec![],
        },
        ..Default::default()
    };
    (
        Arc::new(Scene::load(&path, &opts).expect("the ball's scene")),
        triangles,
    )
}

/// A moving object's cost by its triangles: the wall's 1024 × 768 visibility on all cores
/// with a ball of 48 to 260 k triangles (about 9 % of the pixels see it) in the static scene,
/// against the same ball as a moving object (its own BVH walked under its placement).
fn objects_by_triangles(c: &mut Criterion) {
    let dir = tempfile::tempdir().expect("a scratch folder");
    let mut group = c.benchmark_group("vlf visibility/ball objects");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(4));
    let v = view(Vec3::new(0.0, 1.6, 0.5), -1.5, 1024, 768);
    for (rings, segments) in [(4, 8), (16, 32), (64, 128), (256, 512)] {
        for movable in [false, true] {
            let (scene, triangles) = ball_scene(dir.path(), rings, segments, movable);
            let vis = Visibility::of(scene, &Settings::default());
            let label = if movable { "moving" } else { "static" };
            group.bench_function(format!("{triangles} triangles, {label}"), |b| {
                b.iter(|| vis.pixels(&v))
            });
        }
    }
    group.finish();
}

/// What a moving object's gathers cost ([`holocave_vlf::object_gather`]): a wall's first
/// frame of the room (128 × 96, as `sim`'s, on all cores; every pixel at a new point, so
/// its objects' and their neighbours' pixels take their first estimates' 16 rays), with the
/// block in the shade filling a fifth of it, against the same frame with the block away.
/// The field a quick bake's (162 directions, 64² lines: the gathers' cost does not depend
/// on it).
fn object_gathers(c: &mut Criterion) {
    use holocave_scene::Placement;
    use holocave_vlf::WallPass;
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/room.gltf");
    let opts = LoadOptions::with_objects(&["block"]);
    let Ok(scene) = Scene::load(&path, &opts) else {
        eprintln!("the room's block is not as this bench expects; skipped");
        return;
    };
    let scene = Arc::new(scene);
    let settings = Settings {
        directions: 162,
        resolution: 64,
        ..Settings::default()
    };
    let (state, _) = holocave_vlf::bake::bake::<std::convert::Infallible>(
        &scene,
        &settings,
        None,
        &|_| {},
        &mut |_| Ok(()),
    )
    .unwrap_or_else(|e| match e {});
    let vis = Visibility::of(scene.clone(), &settings);
    let pass = WallPass::new(vis, &settings, &state, false).expect("a pass");
    let v = WallView {
        eye: Vec3::new(0.9, 1.8, 0.1),
        pa: Vec3::new(0.1622, 0.7174, 0.1612),
        pb: Vec3::new(1.0734, 0.7174, -0.6197),
        pc: Vec3::new(-0.31, 1.6732, -0.3897),
        size: Size::new(128, 96),
    };
    let mut group = c.benchmark_group("vlf wall pass/room.gltf block");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(8));
    for (label, at) in [
        ("in the shade, in view", Vec3::new(-0.3, 0.4, -1.3)),
        ("away", Vec3::splat(1000.0)),
    ] {
        pass.visibility()
            .place_objects(&[Placement::new(at, Quat::IDENTITY)]);
        group.bench_function(
            format!("128x96 first frame, all cores, block {label}"),
            |b| b.iter(|| pass.render(&v, pass.values(), 1, 1)),
        );
    }
    group.finish();
}

criterion_group!(
    benches,
    visibility,
    moving_objects,
    objects_by_triangles,
    object_gathers
);
criterion_main!(benches);
