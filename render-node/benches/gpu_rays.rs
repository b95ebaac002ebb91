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
//!   `gpu_send` and `gpu_receive`: its two halves, the rays made and copied to the GPU, and
//!   the answers copied back and read;
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
use glam::Vec3;
use holocave_render_node::Gpu;
use holocave_render_node::gpu_rays::{GpuRays, Query, adapter_report};
use holocave_scene::bvh::{EDGE_TOLERANCE, FLAT_COUNT_SHIFT, FLAT_EMPTY, FLAT_LEAF, FlatBvh};
use holocave_scene::{Ray, Scene};
use ray_sets::{camera_view, project_scene, ray_sets as sets_through, sponza};
use rayon::prelude::*;

/// What the GPU walk does for a ray, counted by the same walk on the CPU (`rays.wgsl`'s
/// `closest` and `any_hit`, step for step): nodes visited, child boxes tested, triangles
/// tested, and the most stack entries held.
#[derive(Default, Clone, Copy)]
struct Counts {
    nodes: u64,
    boxes: u64,
    triangles: u64,
    stack: u64,
}

/// The shader's walk over `flat` for `ray` (closest hit, or any hit), counting.
fn walk(flat: &FlatBvh, ray: &Ray, tmax: f32, closest: bool) -> Counts {
    let mut c = Counts::default();
    let (o, d) = (ray.origin, ray.dir);
    let inv = Vec3::ONE / d.abs().max(Vec3::splat(1e-30)).copysign(d);
    let neg = [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0];
    let oct = usize::from(d.x < 0.0) * 4 + usize::from(d.y < 0.0) * 2 + usize::from(d.z < 0.0);
    let f = f32::from_bits;
    let far_grow = 1.0 + 16.0 * f32::EPSILON;
    let mut stack = vec![(0u32, 0.0f32)];
    let mut best = tmax;
    while let Some((child, entry)) = stack.pop() {
        if closest && entry > best {
            continue;
        }
        if child & FLAT_LEAF == 0 {
            c.nodes += 1;
            let node = &flat.nodes[child as usize];
            for k in 0..8 {
                let slot = ((node[56 + k] >> (3 * oct)) & 7) as usize;
                let ch = node[48 + slot];
                if ch == FLAT_EMPTY {
                    continue;
                }
                c.boxes += 1;
                let plane = |row: usize| f(node[8 * row + slot]);
                let (mut near, mut far) = (0.0f32, f32::INFINITY);
                for axis in 0..3 {
                    let (lo, hi) = (plane(axis), plane(axis + 3));
                    let (a, b) = if neg[axis] { (hi, lo) } else { (lo, hi) };
                    near = near.max((a - o[axis]) * inv[axis]);
                    far = far.min((b - o[axis]) * inv[axis]);
                }
                if near <= (far * far_grow).min(best) {
                    stack.push((ch, near));
                }
            }
            c.stack = c.stack.max(stack.len() as u64);
        } else {
            let first = 4 * (child & ((1 << FLAT_COUNT_SHIFT) - 1));
            let count = (child & !FLAT_LEAF) >> FLAT_COUNT_SHIFT;
            for slot in first..first + count {
                c.triangles += 1;
                let w = &flat.triangles[slot as usize];
                let v = |i: usize| Vec3::new(f(w[i]), f(w[i + 1]), f(w[i + 2]));
                let (v0, e1, e2) = (v(0), v(4), v(8));
                let p = d.cross(e2);
                let inv_det = 1.0 / e1.dot(p);
                let s = o - v0;
                let q = s.cross(e1);
                let (u, vv, t) = (s.dot(p) * inv_det, d.dot(q) * inv_det, e2.dot(q) * inv_det);
                let tol = EDGE_TOLERANCE;
                if u >= -tol
                    && u <= 1.0 + tol
                    && vv >= -tol
                    && u + vv <= 1.0 + tol
                    && t >= 0.0
                    && t < best
                {
                    if !closest {
                        return c;
                    }
                    best = t;
                }
            }
        }
    }
    c
}

/// Prints, per ray of `rays`, what the GPU walk does and the bytes it fetches: a node is
/// 256 B, a triangle slot 48 B, a ray 32 B and its answer 16 B (closest) or 4 B (any). On
/// a GPU the walk is bound by these fetches where they miss the caches: rays/s ≈ bandwidth
/// ÷ bytes per ray at worst (every fetch from memory), far better where nodes near the
/// root stay in L2.
fn print_counts(name: &str, set: &str, flat: &FlatBvh, rays: &[Ray], closest: bool) {
    let mut sum = Counts::default();
    for r in rays {
        let c = walk(flat, r, f32::INFINITY, closest);
        sum.nodes += c.nodes;
        sum.boxes += c.boxes;
        sum.triangles += c.triangles;
        sum.stack = sum.stack.max(c.stack);
    }
    let n = rays.len().max(1) as f64;
    let (nodes, boxes, tris) = (
        sum.nodes as f64 / n,
        sum.boxes as f64 / n,
        sum.triangles as f64 / n,
    );
    let bytes = nodes * 256.0 + tris * 48.0 + 32.0 + if closest { 16.0 } else { 4.0 };
    // The shader's arithmetic, counted by hand from rays.wgsl: a box test is 6 loads, 6
    // subtractions, 6 multiplications, 6 min/max, 1 multiplication and 2 comparisons, plus
    // the slot's order and child words and a push (about 33); a triangle test is 9 loads
    // and 33 arithmetic operations plus the comparisons (about 50); a node visit's own
    // bookkeeping (pop, test, branch) about 10.
    let ops = 33.0 * boxes + 50.0 * tris + 10.0 * nodes;
    eprintln!(
        "gpu_rays bench: {name} {set}: per ray {nodes:.1} nodes visited, {boxes:.1} boxes and \
         {tris:.1} triangles tested, {bytes:.0} B fetched, about {ops:.0} operations; deepest \
         stack {} entries",
        sum.stack
    );
}

/// One scene's sets through the GPU and the CPU walks.
fn bench_scene(c: &mut Criterion, gpu: &Gpu, name: &str, scene: &Scene, width: u32, height: u32) {
    let mut engine = GpuRays::for_scene(gpu, scene).expect("upload the scene");
    let view = camera_view(scene, width, height);
    let sets = sets_through(scene, &view);
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
    let flat = scene.bvh().flat();
    print_counts(name, "primary", &flat, &sets.primary, true);
    print_counts(name, "shadow", &flat, &sets.shadow, false);
    print_counts(name, "diffuse", &flat, &sets.diffuse, true);
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
        // The round trip's two halves: the rays sent (made, copied out, on the GPU), and
        // the last walk's answers received (copied back, read).
        group.bench_function(format!("{set}_gpu_send"), |b| {
            b.iter(|| {
                engine.upload(gpu, rays, inf);
                gpu.wait();
            })
        });
        engine.trace(gpu, n, query);
        group.bench_function(format!("{set}_gpu_receive"), |b| {
            b.iter(|| match query {
                Query::ClosestHit => black_box(engine.read_hits(gpu, n).len()),
                Query::AnyHit => black_box(engine.read_occluders(gpu, n).len()),
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
