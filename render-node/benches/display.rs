//! Display-process time per frame, split by step, at 512×512 and 1024×768 per eye, both
//! eyes (and at 1024×768 with the room's light field under the cache), on whatever adapter wgpu finds (Mesa's lavapipe on machines without a GPU). The
//! cache holds 1.25 points per pixel of both eyes, filled with one point per pixel seen
//! from each eye; each frame chooses 1/16 of the pixels per eye. Per-step figures come from
//! submitting each step alone and waiting for it, so they include one submit and wait each.

use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};

mod common;
use common::views;
use glam::Vec2;
use holocave_cave::Size;
use holocave_render_node::{EyeView, Gpu, NewSample, RenderCache, StepTimes};
use holocave_vlf::Lookup;

/// The room's light field as a node draws it: the default bake's element layout (the
/// irradiance values do not change the cost) and each eye's lookups from the node's own
/// ray casts, so the shader reads the atlas as coherently as it does in use.
fn room_lookups(views: &[EyeView]) -> (usize, Vec<Vec<Lookup>>) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/room.gltf");
    let scene = std::sync::Arc::new(
        holocave_scene::Scene::load(&path, &holocave_scene::LoadOptions::default())
            .expect("the room"),
    );
    let vis = holocave_vlf::Visibility::of(scene, &holocave_vlf::Settings::default());
    let count = vis.elements().count + vis.tiles().len();
    (count, views.iter().map(|v| vis.pixels(&v.wall)).collect())
}

fn bench_size(c: &mut Criterion, w: u32, h: u32, vlf: bool) {
    let gpu = match Gpu::new() {
        Ok(g) => g,
        Err(e) => {
            eprintln!("skipping: {e}");
            return;
        }
    };
    let adapter = gpu.adapter.clone();
    let n = w * h;
    let budget = n / 16;
    let mut cache = RenderCache::new(
        gpu,
        &[Size::new(w, h), Size::new(w, h)],
        2 * n * 5 / 4,
        budget * 2,
    );
    let vs = views(w, h);
    if vlf {
        let (count, lookups) = room_lookups(&vs);
        cache
            .set_vlf(&vec![[1.0, 0.5, 0.25]; count], 256.0)
            .expect("the values fit");
        for (e, l) in lookups.iter().enumerate() {
            cache.set_lookups(e, l);
        }
    }
    let tag = if vlf { " with the light field" } else { "" };
    // Fill: a room-like depth field (a box 1.5 m around the eye) seen from each eye.
    cache.draw(&vs, &[0, 0], false, &mut StepTimes::default());
    for (e, v) in vs.iter().enumerate() {
        let samples: Vec<NewSample> = (0..n)
            .map(|i| {
                let r = v
                    .wall
                    .ray(Vec2::new((i % w) as f32 + 0.5, (i / w) as f32 + 0.5));
                let d = 1.5 / r.dir.z.abs().max(r.dir.x.abs()).max(0.2);
                let c = (i % 7) as f32 / 7.0;
                NewSample::new(i, r.origin, r.at(d), d, [c, 0.5, 1.0 - c], 1)
            })
            .collect();
        cache.insert(e, &samples);
    }
    let mut steps = StepTimes::default();
    let mut frames = 0u32;
    let mut group = c.benchmark_group(format!("display/{w}x{h} stereo{tag}"));
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(10));
    group.bench_function("frame (all steps, one submit)", |b| {
        b.iter(|| cache.draw(&vs, &[budget, budget], false, &mut StepTimes::default()))
    });
    group.bench_function("frame (steps timed one by one)", |b| {
        b.iter(|| {
            frames += 1;
            cache.draw(&vs, &[budget, budget], true, &mut steps)
        })
    });
    group.finish();
    let ms = |d: Duration| d.as_secs_f64() * 1e3 / f64::from(frames.max(1));
    eprintln!(
        "\n{w}x{h} per eye, 2 eyes{tag}, {adapter}: per frame over {frames} timed frames (ms)\n\
         clear {:.2} | projection {:.2} | depth cull {:.2} | interpolation+priority {:.2} | \
         light field {:.2} | dither {:.2} | aging {:.2} | chosen read-back {:.2} | total {:.2}\n",
        ms(steps.clear),
        ms(steps.projection),
        ms(steps.depth_cull),
        ms(steps.interpolation_priority),
        ms(steps.vlf),
        ms(steps.dither),
        ms(steps.aging),
        ms(steps.readback),
        ms(steps.total())
    );
}

fn display(c: &mut Criterion) {
    bench_size(c, 512, 512, false);
    for Size {
        width: w,
        height: h,
    } in common::sizes(&[Size::new(1024, 768)])
    {
        bench_size(c, w, h, false);
        bench_size(c, w, h, true);
    }
}

criterion_group!(benches, display);
criterion_main!(benches);
