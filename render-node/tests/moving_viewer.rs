//! Done-when 2 of issue 5 (in part): a moving viewer following a recorded head trace
//! (`../shared/tracking/pred6dof/1.csv`, HoloLens, recentred in front of the Cornell box),
//! both eyes, 64×64 per eye, a sixteenth of the pixels traced per eye and frame.
//! Checks that no frame is left black where samples exist (coverage after the first
//! frames), that every frame traces its fixed budget per eye and no more (what bounds a
//! frame's cost; its speed is the `display` benchmark's business, not a test's), and that
//! the error of a few frames against path-traced references stays near that of a
//! path-traced frame with as many rays.

use crate::common;

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::Vec3;
use holocave_cave::Size;
use holocave_render_node::{EyeView, FrameReport, Gpu, PixelTracer, RenderCache, WallDisplay};
use holocave_tracer::film::Image;
use holocave_tracer::{TraceSettings, Tracer, render::render};
use holocave_tracking::csv_log::read_csv;

const SIZE: u32 = 64;
const FRAMES: u64 = 120;
const FPS: f64 = 60.0;
const IPD: f32 = 0.064;
/// How many times a path-traced frame's error (with as many rays) the cache's may be at
/// any of frames 29/59/89/119, and summed over the four (`overall_ratio`). Derived from
/// `moving_viewer_error_ratios_over_runs` (lavapipe, 2026-12-03), runs 0..20 (tracer and
/// reference seeds varied):
/// - M, a run's largest ratio over the four frames: 2.06 2.10 1.48 2.69 2.37 1.93 2.06
///   1.44 1.81 2.03 2.12 2.43 1.96 2.09 1.59 1.60 2.22 1.36 2.37 1.93; ln M of mean 0.668,
///   standard deviation 0.186 (n = 20);
/// - S, the four frames' errors summed over the path-traced frames': 1.56 1.36 1.24 1.49
///   1.59 1.44 1.51 1.19 1.32 1.17 1.57 1.31 1.44 1.54 1.29 1.36 1.36 1.22 1.31 1.44;
///   ln S of mean 0.321, standard deviation 0.095.
///
/// Taking ln M and ln S as normal, a new run stays below the one-sided 99% prediction
/// bound exp(mean + t(19, 0.99) · sd · √(1 + 1/n)), t(19, 0.99) = 2.539:
///   M: exp(0.668 + 2.539 · 0.186 · 1.025) = exp(1.152) = 3.16, rounded up to 3.2;
///   S: exp(0.321 + 2.539 · 0.095 · 1.025) = exp(0.568) = 1.76, rounded up to 1.8.
/// (The old bound, 2× at every frame, was exceeded by 11 of the 20 runs.) A cache with a
/// fifth of the points (`2 * n / 4`) scores M 3.07 and S 2.05: S catches it.
const ERROR_RATIO_BOUND: f64 = 3.2;
const OVERALL_RATIO_BOUND: f64 = 1.8;

#[test]
fn moving_viewer_follows_a_recorded_trace() {
    follow_a_recorded_trace(0);
}

/// The cache's error during motion against a path-traced frame with as many rays, at
/// frames 29/59/89/119 (clamped relative MSE, see below): within [`ERROR_RATIO_BOUND`] at
/// each, and within [`OVERALL_RATIO_BOUND`] summed over the four.
///
/// Repeatable: the CPU side is seeded and the cache's GPU passes give the same result in
/// any order (before, the insert pass aged points racily and the dither's list came back
/// in thread order, so runs differed and the test, then bounded at 2×, passed in about 7
/// runs of 10). Run 0's ratios are 1.08/1.62/1.83/2.06, 1.56 summed.
///
/// The bound is derived from how the ratio varies with the seeds, not from run 0: the
/// ignored `moving_viewer_error_ratios_over_runs` plays runs 0..20 (tracer and reference
/// seeds varied) and prints each run's largest ratio over the four frames, M (the
/// figures and the maths at [`ERROR_RATIO_BOUND`]).
#[test]
fn moving_viewer_error_stays_within_a_bound_of_a_path_traced_frame() {
    let Some(errors) = follow_a_recorded_trace(0) else {
        return;
    };
    let s = overall_ratio(&errors);
    assert!(
        s < OVERALL_RATIO_BOUND,
        "the cache's errors at the four frames sum to {s:.2}× the path-traced frames' \
         (bound {OVERALL_RATIO_BOUND}×): {errors:.4?}"
    );
    for (k, &(e, baseline)) in errors.iter().enumerate() {
        assert!(
            e < ERROR_RATIO_BOUND * baseline,
            "frame {}: clamped relative MSE {e:.4}, {:.2}× a path-traced frame's {baseline:.4} \
             with as many rays (bound {ERROR_RATIO_BOUND}×)",
            30 * k + 29,
            e / baseline
        );
    }
}

/// Not a check: the distribution behind [`ERROR_RATIO_BOUND`] (`cargo test --release -p
/// holocave-render-node --test moving_viewer -- --ignored --nocapture`).
#[test]
#[ignore]
fn moving_viewer_error_ratios_over_runs() {
    let (mut worst, mut overall) = (Vec::new(), Vec::new());
    for run in 0..20 {
        let Some(errors) = follow_a_recorded_trace(run) else {
            return;
        };
        let ratios: Vec<f64> = errors.iter().map(|(e, b)| e / b).collect();
        let m = ratios.iter().copied().fold(0.0, f64::max);
        let s = overall_ratio(&errors);
        println!("run {run}: ratios {ratios:.3?}, largest {m:.3}, overall {s:.3}");
        worst.push(m);
        overall.push(s);
    }
    for (name, v) in [("largest ratio", &worst), ("overall ratio", &overall)] {
        let logs: Vec<f64> = v.iter().map(|m| m.ln()).collect();
        let n = logs.len() as f64;
        let mean = logs.iter().sum::<f64>() / n;
        let sd = (logs.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        println!(
            "{name} per run: min {:.3}, max {:.3}; ln: mean {mean:.4}, sd {sd:.4}",
            v.iter().copied().fold(f64::INFINITY, f64::min),
            v.iter().copied().fold(0.0, f64::max)
        );
    }
}

/// The cache's errors summed over the measured frames over the path-traced frames'.
fn overall_ratio(errors: &[(f64, f64)]) -> f64 {
    errors.iter().map(|(e, _)| e).sum::<f64>() / errors.iter().map(|(_, b)| b).sum::<f64>()
}

/// Plays the trace (run `run`: the tracer's and the references' seeds); the clamped
/// errors of the cache and of a path-traced frame with as many rays at frames 29, 59, 89
/// and 119, or `None` when the trace is absent (skipped).
fn follow_a_recorded_trace(run: u64) -> Option<Vec<(f64, f64)>> {
    let log_path = common::require::shared("tracking/pred6dof/1.csv")?;
    let log = read_csv(&log_path, None).expect("read the trace");
    let samples = log.samples;
    let t0 = samples[0].t_ns;
    let p0 = samples[0].pose.position;
    let centre = common::EYE;

    let tracer = Arc::new(Tracer::new(
        Arc::new(common::cornell()),
        TraceSettings::default(),
    ));
    let wall = |eye: Vec3| common::front_wall(eye, SIZE);
    let gpu = Gpu::new().expect("a wgpu adapter (install mesa-vulkan-drivers without a GPU)");
    let n = SIZE * SIZE;
    let budget = n / 16;
    let cache = RenderCache::new(
        gpu,
        &[Size::new(SIZE, SIZE), Size::new(SIZE, SIZE)],
        2 * n * 5 / 4,
        budget,
    );
    let mut display = WallDisplay::new(cache, PixelTracer::new(tracer.clone(), 3 + run), budget);

    let mut next = 0usize;
    let mut worst = Duration::ZERO;
    let mut travelled = 0.0f32;
    let mut last_head = centre;
    let mut errors = Vec::new();
    let mut sheet = Vec::new();
    for frame in 0..FRAMES {
        let t = t0 + (frame as f64 / FPS * 1e9) as u64;
        while next + 1 < samples.len() && samples[next + 1].t_ns <= t {
            next += 1;
        }
        let pose = samples[next].pose;
        let head = centre + (pose.position - p0);
        travelled += (head - last_head).length();
        last_head = head;
        let views: Vec<EyeView> = [-0.5f32, 0.5]
            .iter()
            .map(|s| {
                let eye = head + pose.orientation * Vec3::new(s * IPD, 0.0, 0.0);
                EyeView::looking_at(wall(eye), 0.05).unwrap()
            })
            .collect();
        let start = Instant::now();
        let report = display.frame(&views, false);
        worst = worst.max(start.elapsed());
        assert_fixed_budget(&report, frame, budget);
        if frame >= 16 {
            assert_covered(&display, frame);
        }
        if frame % 30 == 29 {
            let (error, row) = measure(&display, &tracer, &views[0], (frame, run), travelled);
            errors.push(error);
            sheet.push(row);
        }
    }
    if let Ok(dir) = std::env::var("HOLOCAVE_TEST_OUT") {
        // Rows: frames 29, 59, 89, 119; columns: left eye, right eye, left reference,
        // a path-traced frame with as many rays.
        std::fs::create_dir_all(&dir).unwrap();
        holocave_render_node::display::contact_sheet(&sheet, 4)
            .save(PathBuf::from(dir).join("moving-sheet.png"))
            .unwrap();
    }
    // For information only: speed is measured by the `display` benchmark.
    eprintln!("worst frame time {:.1} ms", worst.as_secs_f64() * 1e3);
    Some(errors)
}

/// A fixed budget each frame: every eye chooses exactly its budget of pixels (the dither's
/// choice, capped at the budget and topped up where it fell short), and exactly the chosen
/// pixels are traced and inserted.
fn assert_fixed_budget(report: &FrameReport, frame: u64, budget: u32) {
    for (eye, &c) in report.chosen.iter().enumerate() {
        assert_eq!(
            c as u32, budget,
            "frame {frame} eye {eye}: {c} pixels chosen for a budget of {budget}"
        );
    }
    assert_eq!(report.chosen.len(), 2, "frame {frame}: both eyes drawn");
    assert_eq!(
        report.inserted,
        report.chosen.iter().sum::<usize>(),
        "frame {frame}: one sample per chosen pixel, traced and inserted this frame"
    );
}

/// After 16 frames every eye has been sent about one sample per pixel.
fn assert_covered(display: &WallDisplay, frame: u64) {
    for eye in 0..2 {
        let cov = display.cache.coverage(eye);
        let filled = cov.iter().filter(|&&c| c > 0.0).count() as f64 / cov.len() as f64;
        assert!(
            filled > 0.95,
            "frame {frame} eye {eye}: only {:.1}% of the pixels drawn",
            filled * 100.0
        );
    }
}

/// Frame `frame` of run `run` measured on the left eye's `view`: the cache's clamped error
/// and a path-traced frame's with as many rays, both against a 256-spp reference; and the
/// contact sheet's row (both eyes, the reference, the path-traced frame).
fn measure(
    display: &WallDisplay,
    tracer: &Tracer,
    view: &EyeView,
    (frame, run): (u64, u64),
    travelled: f32,
) -> ((f64, f64), Vec<image::RgbImage>) {
    let n = SIZE * SIZE;
    let budget = n / 16;
    // The image shown this frame was drawn before this frame's samples came in:
    // compare it with the reference of this frame's left view.
    let img = display.cache.image(0);
    let reference = render(tracer, &view.wall, 256, frame + (run << 32), &|| {});
    let err = img.relative_mse(&reference);
    // Path-traced fireflies dominate the relative MSE of images of a few samples
    // per pixel (a black image scores about 1); radiance clamped at 1 compares what
    // the eye sees.
    let clamped = clamp(&img).relative_mse(&clamp(&reference));
    // The same number of rays spent on a whole path-traced frame of this view
    // (what the cache has had per pixel so far, had nothing moved).
    let spp = ((frame + 1) * u64::from(budget)).div_ceil(u64::from(n)) as u32;
    let same_rays = render(tracer, &view.wall, spp, frame + 99 + (run << 32), &|| {});
    let baseline = clamp(&same_rays).relative_mse(&clamp(&reference));
    eprintln!(
        "frame {frame}: head moved {travelled:.3} m so far; relative MSE {err:.3}, \
             clamped at 1: {clamped:.4} (a {spp} spp path-traced frame: {baseline:.4})"
    );
    let e = reference.auto_exposure();
    let row = vec![
        img.to_preview(e),
        display.cache.image(1).to_preview(e),
        reference.to_preview(e),
        same_rays.to_preview(e),
    ];
    let pts = display.cache.points();
    let valid: Vec<_> = pts.iter().filter(|p| p.pos[3] < 1e6).collect();
    let mean_count =
        valid.iter().map(|p| f64::from(p.rad[3])).sum::<f64>() / valid.len().max(1) as f64;
    eprintln!(
        "  {} points, mean samples per point {mean_count:.2}",
        valid.len()
    );

    ((clamped, baseline), row)
}

fn clamp(img: &Image) -> Image {
    Image {
        pixels: img.pixels.iter().map(|p| p.min(Vec3::ONE)).collect(),
        ..img.clone()
    }
}
