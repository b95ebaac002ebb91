//! Frusta for a whole CAVE per frame: 4 walls × 2 eyes from one head pose.

use std::hint::black_box;
use std::path::Path;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{Quat, Vec3};
use holocave_cave::{CaveFrusta, load_cave};
use holocave_tracking::Pose;

fn frusta(c: &mut Criterion) {
    let cave = load_cave(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/cave4.toml"))
        .expect("cave4.toml");
    let mut frusta = CaveFrusta::new(&cave);
    let mut i = 0u32;
    c.bench_function("cave4 frusta (4 walls x 2 eyes)", |b| {
        b.iter(|| {
            i = i.wrapping_add(1);
            let t = (i % 1000) as f32 * 1e-3;
            let head = Pose::new(Vec3::new(0.3 * t, 1.7, -0.2 * t), Quat::from_rotation_y(t));
            frusta.update(&cave, black_box(&head));
            black_box(&frusta.walls[0].eyes[0]);
        })
    });
}

criterion_group!(benches, frusta);
criterion_main!(benches);
