//! A wall's per-pixel work per frame, both eyes, still (after its first frames: its
//! surfaces drawn again, its settled means taking no estimates), with the head moving and
//! on views never seen before (a first frame's cost), with each
//! pixel's first hit traced on the CPU and on the GPU (`--rays cpu|gpu`): the light field's
//! lookups with the direct light per pixel (`VlfBase::lookups`: first hits, mirrors and
//! glass, 1 + P + 1 shadow rays, the running means), at 128×96 and 1024×768 per eye (and
//! `HOLOCAVE_BENCH_WALL`'s size), in the room, on whatever adapter wgpu finds (lavapipe
//! where there is no GPU). The render cache's passes at these sizes
//! are `benches/display.rs`; a wall's frame is the two together.

use std::sync::Arc;

use criterion::{Criterion, criterion_group, criterion_main};

mod common;
use common::views;
use holocave_cave::Size;
use holocave_render_node::gpu_rays::Rays;
use holocave_render_node::{EyeView, Gpu, VlfBase};
use holocave_scene::{LoadOptions, Scene};
use holocave_vlf::{Settings, VlfFile, bake};

/// The room's light field, baked coarsely (its values do not change the lookups' cost;
/// its element layout is the default's).
fn room_field(dir: &std::path::Path) -> (Arc<Scene>, std::path::PathBuf) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/room.gltf");
    let scene = Arc::new(Scene::load(&path, &LoadOptions::default()).expect("the room"));
    let settings = Settings {
        directions: 12,
        resolution: 16,
        ..Settings::default()
    };
    let (state, _) =
        bake::<std::convert::Infallible>(&scene, &settings, None, &|_| {}, &mut |_| Ok(()))
            .unwrap_or_else(|e| match e {});
    let file = dir.join("room.vlf");
    VlfFile::of(&scene, settings, state)
        .write(&file)
        .expect("write the light field");
    (scene, file)
}

/// `views` with both eyes moved `dx` metres sideways.
fn moved(views: &[EyeView], dx: f32) -> Vec<EyeView> {
    views
        .iter()
        .map(|v| {
            let mut wall = v.wall;
            wall.eye.x += dx;
            EyeView::looking_at(wall, v.near).expect("the eye is in front of the wall")
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let gpu = match Gpu::new() {
        Ok(g) => g,
        Err(e) => {
            eprintln!("skipping: {e}");
            return;
        }
    };
    let dir = tempfile::tempdir().expect("a temporary folder");
    let (scene, file) = room_field(dir.path());
    eprintln!("adapter: {}", gpu.adapter);
    for rays in [Rays::Cpu, Rays::Gpu] {
        let base = VlfBase::open(&file, scene.clone())
            .and_then(|b| b.with_rays(&gpu, rays))
            .expect("open the light field");
        for Size {
            width: w,
            height: h,
        } in common::sizes(&[Size::new(128, 96), Size::new(1024, 768)])
        {
            let views = views(w, h);
            let mut g = c.benchmark_group(format!("wall_frame/{w}x{h}"));
            g.sample_size(10);
            g.bench_function(format!("rays {rays}"), |b| {
                b.iter(|| {
                    for (eye, v) in views.iter().enumerate() {
                        std::hint::black_box(base.lookups(eye, v));
                    }
                })
            });
            // A head moving sideways at 15 cm/s, drawn at 30 Hz: 5 mm a frame, each eye's
            // means carried over from where it was (what a tracked viewer costs).
            let frame = std::cell::Cell::new(0u32);
            g.bench_function(format!("rays {rays}, moving"), |b| {
                b.iter(|| {
                    let f = frame.get();
                    frame.set(f + 1);
                    let dx = 0.005 * (f % 200) as f32;
                    for (eye, v) in moved(&views, dx).iter().enumerate() {
                        std::hint::black_box(base.lookups(eye, v));
                    }
                })
            });
            // Every frame a view not seen before (the eye jumps 30 cm): the pixels'
            // surfaces traced and every mean started again, as on a view's first frame.
            let jump = std::cell::Cell::new(0u32);
            g.bench_function(format!("rays {rays}, first frames"), |b| {
                b.iter(|| {
                    let f = jump.get();
                    jump.set(f + 1);
                    let dx = 0.3 * (f % 5) as f32 - 0.6;
                    for (eye, v) in moved(&views, dx).iter().enumerate() {
                        std::hint::black_box(base.lookups(eye, v));
                    }
                })
            });
            g.finish();
        }
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
