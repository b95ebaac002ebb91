//! A display run is repeatable: the same views and seed give the same pictures, the same
//! chosen pixels and the same cache, bit for bit, whatever order the GPU runs its
//! invocations in (lavapipe uses a thread per core). Two races made runs differ before:
//! the insert pass aged the points around a changed sample while other invocations
//! rewrote them, and the dither's list of chosen pixels came back in thread order (so the
//! tracer's random numbers went to other pixels, and an overfull list lost other pixels).
//! With several GPU threads two 256×192 runs of `holocave node --sync` then differed
//! every time (four runs, four results); on one thread (`LP_NUM_THREADS=1`) they agreed.
//! With those races put back, this test failed in 3 of 4 runs (2-thread lavapipe, at
//! 128×128 and four runs compared; it compares four runs so that a race shows); on a
//! one-thread adapter it cannot tell.

use crate::common;

use std::sync::Arc;

use glam::Vec3;
use holocave_cave::Size;
use holocave_render_node::{EyeView, Gpu, PixelTracer, RenderCache, WallDisplay};
use holocave_tracer::{TraceSettings, Tracer};

const SIZE: u32 = 128;
const FRAMES: u32 = 30;

/// Per frame, both eyes' chosen pixels; at the end, both eyes' pictures and every point.
type Run = (Vec<Vec<Vec<u32>>>, Vec<Vec<[u32; 3]>>, Vec<[u32; 12]>);

/// Two eyes of a head moving sideways and forwards (samples join points from other eye
/// positions, and changed ones age their neighbours), a sixteenth of the pixels per eye
/// and frame traced between frames; a list of chosen pixels with room for only the budget
/// (so the dither's list sometimes overflows).
fn run(tracer: &Arc<Tracer>) -> Run {
    let gpu = Gpu::new().expect("a wgpu adapter (install mesa-vulkan-drivers without a GPU)");
    let n = SIZE * SIZE;
    let budget = n / 16;
    let cache = RenderCache::new(
        gpu,
        &[Size::new(SIZE, SIZE), Size::new(SIZE, SIZE)],
        n * 2,
        budget,
    );
    let mut display = WallDisplay::new(cache, PixelTracer::new(tracer.clone(), 11), budget);
    let mut chosen = Vec::new();
    for frame in 0..FRAMES {
        let head = common::EYE + Vec3::new(0.01, 0.0, -0.005) * frame as f32;
        let views: Vec<EyeView> = [-0.032f32, 0.032]
            .iter()
            .map(|dx| {
                let wall = common::front_wall(head + Vec3::new(*dx, 0.0, 0.0), SIZE);
                EyeView::looking_at(wall, 0.05).unwrap()
            })
            .collect();
        display.frame(&views, false);
        chosen.push(
            (0..2)
                .map(|e| {
                    let img = display.cache.chosen_image(e);
                    (0..img.pixels.len() as u32)
                        .filter(|&i| img.pixels[i as usize] != Vec3::ZERO)
                        .collect()
                })
                .collect::<Vec<Vec<u32>>>(),
        );
    }
    let bits = |v: Vec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
    let images = (0..2)
        .map(|e| {
            display
                .cache
                .image(e)
                .pixels
                .into_iter()
                .map(bits)
                .collect()
        })
        .collect();
    let points = display
        .cache
        .points()
        .iter()
        .map(|p| {
            let mut w = [0u32; 12];
            for (o, v) in w
                .iter_mut()
                .zip(p.pos.iter().chain(&p.rad).chain(&p.origin))
            {
                *o = v.to_bits();
            }
            w
        })
        .collect();
    (chosen, images, points)
}

#[test]
fn the_same_views_and_seed_give_the_same_cache_bit_for_bit() {
    let tracer = Arc::new(Tracer::new(
        Arc::new(common::cornell()),
        TraceSettings::default(),
    ));
    let first = run(&tracer);
    let lit = first.1[0]
        .iter()
        .filter(|p| p.iter().any(|&c| c != 0))
        .count();
    assert!(
        lit * 2 > (SIZE * SIZE) as usize,
        "only {lit} pixels drawn: the run proves little"
    );
    for again in 1..=3 {
        let other = run(&tracer);
        for (frame, (a, b)) in first.0.iter().zip(&other.0).enumerate() {
            assert_eq!(a, b, "run {again}, frame {frame}: other pixels chosen");
        }
        for eye in 0..2 {
            let differ = (first.1[eye].iter().zip(&other.1[eye]))
                .filter(|(a, b)| a != b)
                .count();
            assert_eq!(differ, 0, "run {again}, eye {eye}: {differ} pixels differ");
        }
        let differ = (first.2.iter().zip(&other.2))
            .filter(|(a, b)| a != b)
            .count();
        assert_eq!(differ, 0, "run {again}: {differ} points differ");
    }
}
