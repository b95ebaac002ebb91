//! The display never waits for rays: with the tracer on its own thread and made slow on
//! purpose (no Russian roulette: every path runs to 64 bounces), frames keep coming while
//! batches are traced, and the picture still fills in as they arrive.

use crate::common;

use std::sync::Arc;
use std::time::{Duration, Instant};

use holocave_cave::Size;
use holocave_render_node::{EyeView, Gpu, PixelTracer, RenderCache, SampleFeed, WallDisplay};
use holocave_tracer::{TraceSettings, Tracer};

/// Frames the display must draw, on average, per batch of samples that arrives. A display
/// that waited for its batch in flight would draw one frame per batch (every frame but
/// the first few ends its wait with an arrival; a display made to wait drew 307 frames
/// for 305 batches), so a ratio of two or more means frames went on while batches were
/// traced: two is the smallest whole ratio a waiting display cannot reach. (Measured: 4
/// to 13 per batch, 1341 frames for 308 batches on a loaded machine, 1550 for 122.)
const MIN_FRAMES_PER_BATCH: u32 = 2;

#[test]
fn frames_do_not_wait_for_the_tracer() {
    let scene = common::cornell();
    let slow = TraceSettings {
        max_depth: 64,
        roulette_depth: 64,
    };
    let tracer = Arc::new(Tracer::new(Arc::new(scene), slow));
    let size = 64;
    let view = EyeView::looking_at(common::front_wall(common::EYE, size), 0.05).unwrap();
    let gpu = Gpu::new().expect("a wgpu adapter (install mesa-vulkan-drivers without a GPU)");
    let n = size * size;
    let cache = RenderCache::new(gpu, &[Size::new(size, size)], n * 2, n);
    let mut display = WallDisplay::threaded(cache, PixelTracer::new(tracer, 5), n);

    let start = Instant::now();
    let (mut frames, mut arrivals) = (0u32, 0u32);
    while start.elapsed() < Duration::from_secs(3) {
        let r = display.frame(&[view], false);
        frames += 1;
        arrivals += u32::from(r.inserted > 0);
        assert_eq!(r.trace, Duration::ZERO, "no tracing on the display thread");
    }
    eprintln!("{frames} frames, {arrivals} of them with a batch of samples");
    assert!(arrivals >= 1, "no batch arrived in 3 s");
    assert!(
        frames >= MIN_FRAMES_PER_BATCH * arrivals,
        "{frames} frames for {arrivals} batches (needs {MIN_FRAMES_PER_BATCH} per batch): the \
         display waited for the tracer"
    );
    // Let the last batch land; the picture is mostly drawn by now.
    if let SampleFeed::Thread(t) = &mut display.feed {
        for (eye, s) in t.finish() {
            display.cache.insert(eye, &s);
        }
    }
    display.frame(&[view], false);
    let cov = display.cache.coverage(0);
    let drawn = cov.iter().filter(|&&c| c > 0.0).count() as f64 / cov.len() as f64;
    assert!(
        drawn > 0.9,
        "only {:.0}% of the pixels drawn",
        drawn * 100.0
    );
}
