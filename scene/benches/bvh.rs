//! BVH benchmarks on one core: build time, and closest-hit throughput for primary rays
//! (a pinhole camera at the scene's first glTF camera, 256 × 256 rays through the pixel
//! centres, traced one after another on the calling thread; and the same traced in packets
//! of 4 × 4 pixels, at 256 × 256 and at a wall's 1024 × 1024).
//!
//! Scenes: the project's Cornell box (`scenes/cornell.gltf`) and Sponza from the shared
//! scenes beside the checkout (`../shared/scenes/sponza/Sponza.gltf`), which is skipped
//! with a message when absent.
//!
//! `cargo bench -p holocave-scene --bench bvh`; criterion reports the ray throughput as
//! elements/s, i.e. rays/s.

use std::hint::black_box;
use std::path::{Path, PathBuf};

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use holocave_scene::bvh::Bvh;
use holocave_scene::{LoadOptions, Ray, Scene};

/// The image the primary rays go through (square): the figure comparable with earlier
/// measurements, and a wall's resolution, where neighbouring rays are more alike.
const SIZE: u32 = 256;
const WALL_SIZE: u32 = 1024;

fn scenes() -> Vec<(&'static str, Scene)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let candidates: [(&str, PathBuf); 2] = [
        ("cornell", root.join("scenes/cornell.gltf")),
        ("sponza", root.join("../shared/scenes/sponza/Sponza.gltf")),
    ];
    let mut out = Vec::new();
    for (name, path) in candidates {
        if !path.exists() {
            eprintln!(
                "bvh bench: {} is absent; skipping the {name} benchmarks",
                path.display()
            );
            continue;
        }
        match Scene::load(&path, &LoadOptions::default()) {
            Ok(s) => out.push((name, s)),
            Err(e) => eprintln!("bvh bench: skipping {name}: {e}"),
        }
    }
    out
}

/// Primary rays through the pixel centres of the scene's first camera, `size` × `size`
/// (row by row, as a renderer would issue them).
fn primary_rays(scene: &Scene, size: u32) -> Option<Vec<Ray>> {
    let cam = scene.cameras.first()?;
    let [pa, pb, pc] = cam.screen(1.0);
    let mut rays = Vec::with_capacity((size * size) as usize);
    for y in 0..size {
        for x in 0..size {
            let s = (x as f32 + 0.5) / size as f32;
            let t = 1.0 - (y as f32 + 0.5) / size as f32;
            let p = pa + (pb - pa) * s + (pc - pa) * t;
            rays.push(Ray::new(cam.position, (p - cam.position).normalize()));
        }
    }
    Some(rays)
}

/// The same rays reordered into tiles four pixels wide and a packet's worth of pixels in
/// all, so that each packet of consecutive rays covers one tile.
fn in_tiles(rays: &[Ray], size: u32) -> Vec<Ray> {
    let tall = holocave_scene::bvh::PACKET as u32 / 4;
    let mut out = Vec::with_capacity(rays.len());
    for ty in (0..size).step_by(tall as usize) {
        for tx in (0..size).step_by(4) {
            for y in ty..ty + tall {
                for x in tx..tx + 4 {
                    out.push(rays[(y * size + x) as usize]);
                }
            }
        }
    }
    out
}

fn bvh(c: &mut Criterion) {
    let scenes = scenes();

    let mut build = c.benchmark_group("bvh_build");
    build.sample_size(10);
    for (name, scene) in &scenes {
        let tris: Vec<[Vec3; 3]> = (0..scene.triangle_count() as u32)
            .map(|i| *scene.triangle(i))
            .collect();
        build.throughput(Throughput::Elements(tris.len() as u64));
        build.bench_with_input(BenchmarkId::from_parameter(name), &tris, |b, tris| {
            b.iter(|| Bvh::build(black_box(tris)))
        });
    }
    build.finish();

    let mut closest = c.benchmark_group("closest_hit_primary");
    for (name, scene) in &scenes {
        let Some(rays) = primary_rays(scene, SIZE) else {
            eprintln!("bvh bench: {name} has no camera; skipping its primary rays");
            continue;
        };
        let hits = rays
            .iter()
            .filter(|r| scene.closest_hit(r, f32::INFINITY).is_some())
            .count();
        eprintln!(
            "bvh bench: {name}: {} triangles, camera {:?}, {hits} of {} primary rays hit",
            scene.triangle_count(),
            scene.cameras[0].name,
            rays.len()
        );
        closest.throughput(Throughput::Elements(rays.len() as u64));
        closest.bench_with_input(BenchmarkId::from_parameter(name), &rays, |b, rays| {
            b.iter(|| {
                let mut t_sum = 0.0f32;
                for r in rays {
                    if let Some(h) = scene.closest_hit(r, f32::INFINITY) {
                        t_sum += h.t;
                    }
                }
                black_box(t_sum)
            })
        });
    }
    closest.finish();

    let mut packets = c.benchmark_group("closest_hit_primary_packets");
    for (name, scene) in &scenes {
        for (size, label) in [(SIZE, *name), (WALL_SIZE, &format!("{name}_{WALL_SIZE}"))] {
            let Some(rays) = primary_rays(scene, size) else {
                continue;
            };
            let rays = in_tiles(&rays, size);
            packets.throughput(Throughput::Elements(rays.len() as u64));
            packets.sample_size(if size == SIZE { 100 } else { 10 });
            packets.bench_with_input(BenchmarkId::from_parameter(label), &rays, |b, rays| {
                b.iter(|| {
                    let hits = scene.closest_hits(rays, f32::INFINITY);
                    black_box(hits.iter().flatten().map(|h| h.t).sum::<f32>())
                })
            });
        }
    }
    packets.finish();

    let mut occluded = c.benchmark_group("occluded_primary");
    for (name, scene) in &scenes {
        let Some(rays) = primary_rays(scene, SIZE) else {
            continue;
        };
        occluded.throughput(Throughput::Elements(rays.len() as u64));
        occluded.bench_with_input(BenchmarkId::from_parameter(name), &rays, |b, rays| {
            b.iter(|| {
                rays.iter()
                    .filter(|r| scene.occluded(r, f32::INFINITY))
                    .count()
            })
        });
    }
    occluded.finish();
}

criterion_group!(benches, bvh);
criterion_main!(benches);
