//! One filter + predict step of the head-tracking pipeline (guard, hemisphere, One Euro,
//! predictor update, prediction at the display time), per predictor.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use holocave_tracking::predict::PredictorKind;
use holocave_tracking::synthetic::Motion;
use holocave_tracking::{HeadTracker, TrackingParams};

fn step(c: &mut Criterion) {
    let samples = Motion::Walk.samples(120.0, 10.0);
    for kind in PredictorKind::ALL {
        let mut params = TrackingParams::default();
        params.filter.enabled = true;
        let mut tracker = HeadTracker::with_predictor(&params, kind);
        let mut i = 0usize;
        let mut offset = 0u64;
        c.bench_function(&format!("filter+predict step ({})", kind.name()), |b| {
            b.iter(|| {
                let mut s = samples[i];
                s.t_ns += offset;
                i += 1;
                if i == samples.len() {
                    i = 0;
                    offset += samples[samples.len() - 1].t_ns + 8_333_333;
                }
                tracker.push(black_box(s));
                black_box(tracker.predict(s.t_ns + 50_000_000))
            })
        });
    }
}

criterion_group!(benches, step);
criterion_main!(benches);
