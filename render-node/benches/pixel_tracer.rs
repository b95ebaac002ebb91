//! The node's own samples (`PixelTracer::sample`): a batch of 1/16 of a 256 × 256 eye's
//! pixels of the Cornell box's front-wall view (the README's view), traced by the path
//! tracer and turned into cache samples, one path and four paths per sample; and gather
//! samples over the box's light field with their rays traced on the CPU and on the GPU
//! (`--rays cpu|gpu`, on whatever adapter wgpu finds: lavapipe where there is no GPU).
//! Criterion reports samples per second.

use std::sync::Arc;
use std::time::Duration;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use holocave_render_node::gpu_rays::Rays;
use holocave_render_node::{EyeView, Gpu, PixelTracer, VlfBase};
use holocave_tracer::{TraceSettings, Tracer};
use holocave_vlf::Settings;

#[path = "../tests/common/mod.rs"]
mod common;

const SIZE: u32 = 256;

fn pixel_tracer(c: &mut Criterion) {
    let scene = Arc::new(common::cornell());
    let tracer = Arc::new(Tracer::new(scene.clone(), TraceSettings::default()));
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
    match Gpu::new() {
        Ok(gpu) => {
            let dir = tempfile::tempdir().expect("a temporary folder");
            let file = dir.path().join("cornell.vlf");
            let settings = Settings {
                directions: 92,
                resolution: 64,
                ..Settings::default()
            };
            common::write_field(&scene, settings, &file);
            eprintln!("adapter: {}", gpu.adapter);
            for rays in [Rays::Cpu, Rays::Gpu] {
                let base = VlfBase::open(&file, scene.clone())
                    .and_then(|b| b.with_rays(&gpu, rays))
                    .expect("open the light field");
                let mut source = PixelTracer::new(tracer.clone(), 1).with_gather(Arc::new(base));
                group.bench_function(format!("cornell_gather/rays {rays}"), |b| {
                    b.iter(|| source.sample(&view, &pixels))
                });
            }
        }
        Err(e) => eprintln!("gathers skipped: {e}"),
    }
    group.finish();
}

criterion_group!(benches, pixel_tracer);
criterion_main!(benches);
