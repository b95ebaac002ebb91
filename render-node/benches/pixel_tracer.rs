//! The node's own samples (`PixelTracer::sample`): a batch of 1/16 of a 256 × 256 eye's
//! pixels of the Cornell box's front-wall view (the README's view), traced by the path
//! tracer and turned into cache samples, one path and four paths per sample. Criterion
//! reports samples per second.

use std::sync::Arc;
use std::time::Duration;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use holocave_render_node::{EyeView, PixelTracer};
use holocave_tracer::{TraceSettings, Tracer};

#[path = "../tests/common/mod.rs"]
mod common;

const SIZE: u32 = 256;

fn pixel_tracer(c: &mut Criterion) {
    let tracer = Arc::new(Tracer::new(
        Arc::new(common::cornell()),
        TraceSettings::default(),
    ));
    let view = EyeView::looking_at(common::front_wall(common::EYE, SIZE), 0.05)
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
