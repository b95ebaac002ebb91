//! The node's own samples (`PixelTracer::sample`): a batch of 1/16 of a 256 × 256 eye's
//! pixels of the Cornell box's front-wall view (the README's view), traced by the path
//! tracer and turned into cache samples, one path and four paths per sample. Criterion
//! reports samples per second.

use std::sync::Arc;
use std::time::Duration;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use holocave_render_node::{EyeView, PixelTracer};
use holocave_scene::{LoadOptions, Scene};
use holocave_tracer::view::WallView;
use holocave_tracer::{TraceSettings, Tracer};

const SIZE: u32 = 256;

fn pixel_tracer(c: &mut Criterion) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell.gltf");
    let scene = Scene::load(&path, &LoadOptions::default()).expect("load the Cornell box");
    let tracer = Arc::new(Tracer::new(Arc::new(scene), TraceSettings::default()));
    let view = EyeView::looking_at(
        WallView {
            eye: Vec3::new(0.0, 1.0, 3.4),
            pa: Vec3::new(-1.0, 0.0, 1.2),
            pb: Vec3::new(1.0, 0.0, 1.2),
            pc: Vec3::new(-1.0, 2.0, 1.2),
            width: SIZE,
            height: SIZE,
        },
        0.05,
    )
    .expect("the eye is in front of the wall");
    // Every 16th pixel, spread over the image as a frame's choice is.
    let pixels: Vec<u32> = (0..SIZE * SIZE).step_by(16).collect();
    let mut group = c.benchmark_group("pixel_tracer");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(5))
        .throughput(Throughput::Elements(pixels.len() as u64));
    for paths in [1, 4] {
        let mut source = PixelTracer::new(tracer.clone(), 1).with_paths(paths);
        group.bench_function(format!("cornell_{paths}_path"), |b| {
            b.iter(|| source.sample(&view, &pixels))
        });
    }
    group.finish();
}

criterion_group!(benches, pixel_tracer);
criterion_main!(benches);
