//! Rays per second of the GPU ray engine against the CPU BVH on the same rays:
//! `cargo bench -p holocave-render-node --bench gpu_rays` (criterion reports rays/s as
//! elements/s; Melem/s is Mrays/s).
//!
//! Sets: the room's view through its camera at 256 × 192 (primary, closest hit; diffuse,
//! closest hit; shadow towards the sun, any hit), and Sponza's three sets exactly as
//! `scene/benches/ray_sets.rs` makes them (1024 × 576 primary rays through its first camera)
//! when `../shared/scenes/sponza` is present. For each set:
//!
//! - `gpu`: the walk alone: the rays already in the GPU's buffer, one dispatch and the wait
//!   for it (answers stay on the GPU, as the render node's passes read them);
//! - `gpu_readback`: upload, walk and read the answers back (the CPU-side round trip);
//! - `gpu_wall` (primary only): the wall's rays made on the GPU and traced, one submission;
//! - `cpu_1t`: the CPU walk on one thread; `cpu_all`: on every core (rayon, chunks of 4096).
//!
//! On lavapipe the "GPU" is the same CPU cores (DESIGN.md): there it measures the shader as
//! compiled by llvmpipe, not a GPU. `HOLOCAVE_GPU_RAYS_SCALE=k` multiplies Sponza's
//! resolution by `k` in each axis (2 for 2048 × 1152: enough rays to fill a large GPU).

#[path = "../tests/ray_sets/mod.rs"]
mod ray_sets;

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use holocave_render_node::Gpu;
use holocave_render_node::gpu_rays::{GpuRays, Query, adapter_report};
use holocave_scene::{Ray, Scene};
use ray_sets::{RaySets, camera_view, project_scene, sponza, sun};
use rayon::prelude::*;

/// One scene's sets through the GPU and the CPU walks.
fn bench_scene(c: &mut Criterion, gpu: &Gpu, name: &str, scene: &Scene, width: u32, height: u32) {
    let mut engine = GpuRays::for_scene(gpu, scene).expect("upload the scene");
    let view = camera_view(scene, width, height);
    let sets = RaySets::new(scene, &view, sun());
    eprintln!(
        "gpu_rays bench: {name}, {} triangles, tree {} B + triangles {} B on the GPU, stack {}; \
         {} primary, {} shadow, {} diffuse rays",
        scene.triangle_count(),
        engine.scene_bytes().0,
        engine.scene_bytes().1,
        engine.stack_size(),
        sets.primary.len(),
        sets.shadow.len(),
        sets.diffuse.len()
    );
    let inf = f32::INFINITY;
    let mut group = c.benchmark_group(format!("gpu_rays_{name}"));
    group
        .sampling_mode(SamplingMode::Flat)
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));
    for (set, rays, query) in [
        ("primary", &sets.primary, Query::ClosestHit),
        ("shadow", &sets.shadow, Query::AnyHit),
        ("diffuse", &sets.diffuse, Query::ClosestHit),
    ] {
        let n = rays.len() as u32;
        group.throughput(Throughput::Elements(u64::from(n)));
        engine.upload(gpu, rays, inf);
        group.bench_function(format!("{set}_gpu"), |b| {
            b.iter(|| {
                engine.trace(gpu, n, query);
                gpu.wait();
            })
        });
        group.bench_function(format!("{set}_gpu_readback"), |b| {
            b.iter(|| match query {
                Query::ClosestHit => black_box(engine.closest_hits(gpu, rays, inf).len()),
                Query::AnyHit => black_box(engine.occluders(gpu, rays, inf).len()),
            })
        });
        if set == "primary" {
            group.bench_function(format!("{set}_gpu_wall"), |b| {
                b.iter(|| {
                    engine.trace_wall(gpu, &view, inf, query);
                    gpu.wait();
                })
            });
        }
        let cpu = |rays: &[Ray]| -> f32 {
            match query {
                Query::ClosestHit => rays
                    .iter()
                    .filter_map(|r| scene.closest_hit(r, inf))
                    .map(|h| h.t)
                    .sum(),
                Query::AnyHit => rays.iter().filter(|r| scene.occluded(r, inf)).count() as f32,
            }
        };
        group.bench_function(format!("{set}_cpu_1t"), |b| {
            b.iter(|| black_box(cpu(black_box(rays))))
        });
        group.bench_function(format!("{set}_cpu_all"), |b| {
            b.iter(|| black_box(rays.par_chunks(4096).map(cpu).sum::<f32>()))
        });
    }
    group.finish();
}

fn gpu_rays(c: &mut Criterion) {
    let gpu = match Gpu::new() {
        Ok(g) => g,
        Err(e) => {
            eprintln!("gpu_rays bench: no adapter ({e}); skipping");
            return;
        }
    };
    eprintln!(
        "gpu_rays bench: {}; CPU walk on {} threads\n{}",
        gpu.adapter,
        rayon::current_num_threads(),
        adapter_report(&gpu)
    );
    bench_scene(c, &gpu, "room", &project_scene("room.gltf"), 256, 192);
    if let Some(scene) = sponza() {
        let k: u32 = std::env::var("HOLOCAVE_GPU_RAYS_SCALE")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(1)
            .max(1);
        bench_scene(c, &gpu, "sponza", &scene, 1024 * k, 576 * k);
    }
}

criterion_group!(benches, gpu_rays);
criterion_main!(benches);
