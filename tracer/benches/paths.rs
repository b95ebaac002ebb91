//! Path-traced samples per second on the Cornell box, on one core
//! (`Tracer::trace_serial`): 64 × 64 rays through the pixel centres of camera "front",
//! one full path (NEE + MIS, Russian roulette) per ray.
//!
//! `cargo bench -p holocave-tracer --bench paths`; criterion reports elements/s, i.e.
//! samples/s.

use std::hint::black_box;
use std::path::Path;
use std::sync::Arc;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec2;
use holocave_cave::{Size, WallView};
use holocave_scene::{LoadOptions, Scene};
use holocave_tracer::{TraceSettings, Tracer};

const SIZE: u32 = 64;

fn paths(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell.gltf");
    let scene = match Scene::load(&path, &LoadOptions::default()) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("paths bench: skipped: {e}");
            return;
        }
    };
    let Some(cam) = scene.cameras.iter().find(|c| c.name == "front").cloned() else {
        eprintln!("paths bench: skipped: the Cornell box has no camera \"front\"");
        return;
    };
    let view = WallView::through_camera(&cam, Size::new(SIZE, SIZE));
    let rays: Vec<_> = (0..SIZE * SIZE)
        .map(|i| view.ray(Vec2::new((i % SIZE) as f32 + 0.5, (i / SIZE) as f32 + 0.5)))
        .collect();
    let tracer = Tracer::new(Arc::new(scene), TraceSettings::default());

    let check = tracer.trace_serial(&rays, 0);
    let mean = check.iter().map(|s| s.radiance[0] as f64).sum::<f64>() / check.len() as f64;
    let hit = check.iter().filter(|s| s.distance.is_finite()).count();
    eprintln!(
        "paths bench: cornell, camera \"front\", {} rays, {hit} hit, mean red radiance {mean:.3}",
        rays.len()
    );

    let mut group = c.benchmark_group("path_samples");
    group.throughput(Throughput::Elements(rays.len() as u64));
    let mut seed = 0u64;
    group.bench_function("cornell", |b| {
        b.iter(|| {
            seed += 1;
            let samples = tracer.trace_serial(black_box(&rays), seed);
            black_box(samples.iter().map(|s| s.radiance[0]).sum::<f32>())
        })
    });
    group.finish();
}

criterion_group!(benches, paths);
criterion_main!(benches);
