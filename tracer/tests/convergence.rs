//! Monte Carlo convergence on the Cornell box: the error of an image against a
//! reference of the same view falls like 1/√spp (the relative MSE like 1/spp).
//!
//! Model. A pixel rendered with `n` samples has error variance `σ²/n`. Against a
//! reference of `R` samples, rendered with an independent seed, the expected squared
//! difference is `σ²/n + σ²/R`. With `R = 16 · 4N`, the ratio of the relative MSEs at
//! `N` and `4N` spp is expected to be
//!
//! ```text
//! (1/N + 1/64N) / (1/4N + 1/64N) = 65/17 ≈ 3.82
//! ```
//!
//! (exactly 4 only against a noiseless reference). An estimator with a bias that does
//! not fall with spp, or that stops improving, gives a ratio towards 1; one whose
//! samples are correlated, a ratio below the model too.
//!
//! Tolerance. The glass sphere and the mirror make caustics that path tracing finds
//! only by chance, so a single image's relative MSE is heavy-tailed (at 64 spp it varies
//! by a factor of two between seeds) and pixels are not a reliable sample of its
//! variance. So the spread is measured where it is independent: K = 16 renders at each
//! of N and 4N spp with distinct seeds. With `A`, `B` the means of their relative MSEs
//! and `s_A`, `s_B` the sample standard deviations, the delta method gives
//! `SE(r)² = r² (s_A²/(K A²) + s_B²/(K B²))` for `r = A/B` (the shared reference adds a
//! common term of relative size 1/64 whose fluctuation is negligible). The test accepts
//! `|r − 65/17| ≤ t · SE(r)` with t = 4.07, Student's t for 15 degrees of freedom at a
//! two-sided 1e-3, and checks that this tolerance still excludes ratios of 2 and 8
//! (error falling like spp^-1/4 or spp^-3/4).
//!
//! Cost: 16 × (64 + 256) + 4096 spp at 32 × 32, about 9.4 M paths (~10 s on 2 cores).

use crate::common;

use glam::Vec3;
use holocave_cave::{Size, WallView};
use holocave_tracer::render::render;

fn mean_sd(v: &[f64]) -> (f64, f64) {
    let m = v.iter().sum::<f64>() / v.len() as f64;
    let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64;
    (m, var.sqrt())
}

#[test]
fn cornell_error_falls_like_one_over_sqrt_spp() {
    let scene = common::cornell();
    let cam = scene
        .cameras
        .iter()
        .find(|c| c.name == "front")
        .expect("the Cornell box has a camera named front")
        .clone();
    let view = WallView::through_camera(&cam, Size::new(32, 32));
    let tracer = common::tracer(scene);
    let (n, repeats) = (64u32, 16u64);
    let start = std::time::Instant::now();
    let reference = render(&tracer, &view, 64 * n, 1, &|| {});
    let errors = |spp: u32, seed0: u64| -> Vec<f64> {
        (0..repeats)
            .map(|k| {
                let img = render(&tracer, &view, spp, seed0 + k, &|| {});
                assert!(
                    img.pixels
                        .iter()
                        .all(|p| p.is_finite() && p.min_element() >= 0.0)
                );
                img.relative_mse(&reference)
            })
            .collect()
    };
    let low = errors(n, 100);
    let mid = errors(4 * n, 200);
    eprintln!(
        "rendered {repeats} × {n} + {repeats} × {} + {} spp at 32×32 in {:.1} s",
        4 * n,
        64 * n,
        start.elapsed().as_secs_f64()
    );
    // The box is lit: the reference is far from black, so the relative MSE measures noise.
    let avg = reference.pixels.iter().sum::<Vec3>() / reference.pixels.len() as f32;
    assert!(avg.min_element() > 0.05, "{avg}");

    let ((a, sa), (b, sb)) = (mean_sd(&low), mean_sd(&mid));
    let r = a / b;
    let k = repeats as f64;
    let se = r * (sa * sa / (k * a * a) + sb * sb / (k * b * b)).sqrt();
    let expected = 65.0 / 17.0;
    let t = 4.07;
    eprintln!(
        "relative MSE: {a:.4e} ± {:.1e} at {n} spp, {b:.4e} ± {:.1e} at {} spp; \
         ratio {r:.3} ± {se:.3} (expected {expected:.3})",
        sa / k.sqrt(),
        sb / k.sqrt(),
        4 * n
    );
    assert!(
        (r - expected).abs() <= t * se,
        "ratio {r} ± {se}, expected {expected}: the error does not fall like 1/√spp"
    );
    assert!(
        t * se < (expected - 2.0).min(8.0 - expected),
        "SE {se} too large"
    );
}
