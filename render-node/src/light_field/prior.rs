//! How many samples the light field is worth in a pixel, measured from the samples.
//!
//! A pixel shows `(k V + n C̄) / (k + n)`: the light field's value `V` worth `k` samples,
//! and the mean `C̄` of the `n` samples the render cache holds there (`cache/shade_field.wgsl`).
//! The samples converge to their own mean `μ = E[C]` (a full path's is the true radiance;
//! a gather's is the light field's error seen after one bounce); around it, the shown value
//! has the squared error
//!
//! ```text
//!   (k² (V − μ)² + n σ²) / (k + n)²
//! ```
//!
//! with `σ²` one sample's variance. Its derivative in `k` is `2 n (k b² − σ²) / (k + n)³`
//! with `b² = (V − μ)²`: least at `k = σ² / b²`, whatever `n`. Over many pixels with one
//! `k` the same derivative summed gives `k = Σ σ² / Σ b²` (for a common `n`): the ratio of
//! the sums, not of the means of ratios. Both are measured at the first frame a display
//! draws, on a grid of its pixels, from the samples its own feed makes: `m` samples per
//! pixel give `C̄` and the unbiased variance `s²`, and `(C̄ − V)² − s²/m` is an unbiased
//! estimate of `b²` (its expectation is `b² + σ²/m − σ²/m`). Each term is weighted as the
//! relative MSE weighs its pixel (`1 / (μ² + 0.01)`, with the larger of `V` and `C̄` for
//! `μ`: a pixel either says is bright is bright; the field's value at the pixel's centre
//! misses a lamp half in the pixel, a few samples' mean misses a rare bright path), so the `k` chosen is the one that minimises
//! the figure the walls are judged by. Where `Σ b²` is below twice its own standard error
//! over the pixels, it is taken as that: `k` is never larger than the measure can tell.
//!
//! Samples with heavy tails (a path that finds a lamp over a mirror or through glass by
//! chance) need many per pixel for `C̄` and `s²` to be typical: [`PER_PIXEL`] is 256 over
//! a [`GRID`]² of 16² pixels, 65 536 samples once per display (8 per pixel over 32² took
//! the Cornell box's field's error against gathers for 0.17 instead of 0.01; 32 per pixel
//! measured a path's relative variance at 0.13 where 1024 measure 4.2).
//!
//! Per pixel the maths takes `σ²` and `b²` of that pixel. `b²` of one pixel from its own
//! few samples is noise (a pixel's `(C̄ − V)²` estimates it with the variance of a single
//! sample squared), so the field's error is the display's, relative to `μ² + 0.01`; `σ²`
//! is the pixel's own, from the squared luminance its cached point keeps beside the mean,
//! pooled with the display's [`Measured::spread`] while the point has few samples
//! (`cache/shade_field.wgsl`): where a pixel's samples agree, the field gives way sooner.
//!
//! That is done under full paths only. `k = σ²/b²` is least error against the samples'
//! own mean, which for a path is the true radiance; a gather's mean keeps the field's
//! error one bounce later, and there the pixels whose gathers agree are not the ones
//! where the field is wrong. Measured (`holocave compare`, the Cornell box's front wall,
//! a still head, 10 s, docs/performance/history.md): per pixel, the paths' error at the end fell
//! from 2.82e-3 to 2.21e-3 and the gathers' rose from 1.54e-3 to 2.06e-3; in motion
//! neither moved beyond the runs' spread (per pixel for both feeds `vlf+gather` 0.97× and
//! `vlf+holodeck` 0.99× of `vlf`, 0.98× each with one `k`). Taking each
//! pixel's `b²` from its own samples as well made the gathers 1.26× `vlf`'s error in
//! motion.
//!
//! The field's value in a pixel holds the mean of the pixel's direct-light estimates,
//! whose noise falls as a still view's frames add to it: `b² = b_f² + σ_d²/m` after `m`
//! estimates. The measure takes the field with 16 estimates and with 4 to tell the two
//! apart, and each pixel's samples count by its own `m` ([`Measured::worth_at`], through
//! the lookup's `samples`): measured once at the first frame, one `k` let the room's floor
//! wall's gathers pull a converged still view back towards their own noise (its error
//! rose from frame 60 to 300, ending 1.24 times the field's alone).

use std::str::FromStr;

use glam::{Vec2, Vec3};
use holocave_scene::Ray;
use holocave_scene::color::luminance;
use rand::{Rng, SeedableRng, rngs::SmallRng};

use crate::EyeView;

/// How a display values the light field under its samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Prior {
    /// Measured at the display's first frame from its feed's own samples ([`measure`]).
    Measured,
    /// Worth this many samples in every pixel (0: the samples alone).
    Samples(f32),
}

impl FromStr for Prior {
    type Err = String;
    fn from_str(s: &str) -> Result<Prior, String> {
        if s == "auto" {
            return Ok(Prior::Measured);
        }
        match s.parse::<f32>() {
            Ok(k) if k.is_finite() && k >= 0.0 => Ok(Prior::Samples(k)),
            _ => Err(format!(
                "{s:?} is not a prior: give `auto` (measured) or a number of samples ≥ 0"
            )),
        }
    }
}

impl std::fmt::Display for Prior {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Prior::Measured => f.write_str("auto"),
            Prior::Samples(k) => write!(f, "{k}"),
        }
    }
}

/// The bounds of a measured `k`: at least one sample (a pixel's first sample never
/// outweighs the field on a measure of finitely many pixels), at most what no session
/// reaches (the field alone).
pub const MEASURED_RANGE: (f32, f32) = (1.0, 16384.0);

/// Pixels measured along each side of the view, and samples per pixel.
pub const GRID: u32 = 16;
pub const PER_PIXEL: u32 = 256;

/// What [`measure`] found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measured {
    /// The light field's worth in samples, `Σ σ² / Σ b²` within [`MEASURED_RANGE`].
    pub samples: f32,
    /// `Σ σ²` and `Σ b²` over the pixels, weighted, per pixel and channel.
    pub variance: f64,
    pub bias2: f64,
    /// A sample's variance over `μ² + 0.01`, in luminance, the mean over the pixels: what
    /// a pixel's own spread is set against (`cache/shade_field.wgsl`).
    pub spread: f32,
    /// The share of the squared error `samples` stands for (`variance / samples`) that is
    /// the per-pixel direct light's noise with [`MEASURED_ESTIMATES`] estimates in its
    /// mean (0 where not measured): the part a pixel's running mean takes off as it grows
    /// ([`Measured::worth_at`]).
    pub direct_share: f32,
    pub pixels: usize,
}

/// Direct-light estimates in the mean of the field's values [`measure`] takes, and in the
/// second, smaller mean it takes to tell the direct light's noise from the rest.
pub const MEASURED_ESTIMATES: u32 = 16;
const FEW_ESTIMATES: u32 = 4;

impl Measured {
    /// How much a pixel's samples count, against the field's worth `k` measured, where
    /// the pixel's direct light is the mean of `estimates` estimates: the field's squared
    /// error there over the one measured, `b²(m) / b²(16)` with
    /// `b²(m) = b_f² + σ_d²/m` (the rest's error, and the direct light's noise falling
    /// with the estimates), since `(k V + r n C̄)/(k + r n)` shows the field worth
    /// `k/r = σ²/b²(m)` samples. A still view's pixel, its direct light converging, lets
    /// its samples count less and less; a pixel that starts over, more. No estimates: the
    /// pixel sees no point that takes direct light (the sky, nothing), and its field value
    /// has no such noise to lose: its samples count as measured.
    pub fn worth_at(&self, estimates: u32) -> f32 {
        if estimates == 0 {
            return 1.0;
        }
        let s = self.direct_share.clamp(0.0, 1.0);
        1.0 - s + s * MEASURED_ESTIMATES as f32 / estimates as f32
    }
}

impl std::fmt::Display for Measured {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the light field worth {:.1} samples (a sample's relative variance {:.3e}, in luminance {:.3e}, the field's squared error against the samples' mean {:.3e}, {:.0} % of the error k stands for the direct light's noise at {MEASURED_ESTIMATES} estimates, {} pixels × {PER_PIXEL} samples)",
            self.samples,
            self.variance,
            self.spread,
            self.bias2,
            100.0 * self.direct_share,
            self.pixels
        )
    }
}

/// `k` from the field's value `field[i]` at each pixel and `samples[i]` (at least two)
/// there.
pub fn from_samples(field: &[Vec3], samples: &[Vec<Vec3>]) -> Measured {
    // Per pixel, summed over channels: the weighted variance and the unbiased estimate
    // of the weighted squared bias.
    let terms: Vec<(f64, f64, f64)> = field
        .iter()
        .zip(samples)
        .filter(|(_, s)| s.len() >= 2)
        .map(|(v, s)| {
            let m = s.len() as f64;
            let (mut var, mut bias2) = (0.0, 0.0);
            let lum: Vec<f64> = s.iter().map(|x| f64::from(luminance(*x))).collect();
            let lum_mean = lum.iter().sum::<f64>() / m;
            let lum_s2 = lum.iter().map(|x| (x - lum_mean).powi(2)).sum::<f64>() / (m - 1.0);
            let scale = lum_mean.max(f64::from(luminance(*v))).powi(2) + 0.01;
            for c in 0..3 {
                let xs = s.iter().map(|x| f64::from(x[c]));
                let mean = xs.clone().sum::<f64>() / m;
                let s2 = xs.map(|x| (x - mean).powi(2)).sum::<f64>() / (m - 1.0);
                let r = f64::from(v[c]);
                let w = 1.0 / (r.max(mean).powi(2) + 0.01);
                var += w * s2 / 3.0;
                bias2 += w * ((mean - r).powi(2) - s2 / m) / 3.0;
            }
            (var, bias2, lum_s2 / scale)
        })
        .collect();
    let n = terms.len().max(1) as f64;
    let var = terms.iter().map(|t| t.0).sum::<f64>() / n;
    let bias2 = terms.iter().map(|t| t.1).sum::<f64>() / n;
    // The squared bias is known only to within its standard error: below twice that, the
    // field's error is taken as that large (the largest `k` the measure can support).
    let spread = terms.iter().map(|t| (t.1 - bias2).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    let resolved = bias2.max(2.0 * (spread / n).sqrt());
    let (lo, hi) = MEASURED_RANGE;
    let k = if resolved > 0.0 {
        ((var / resolved) as f32).clamp(lo, hi)
    } else {
        hi
    };
    Measured {
        samples: k,
        variance: var,
        bias2,
        spread: (terms.iter().map(|t| t.2).sum::<f64>() / n) as f32,
        direct_share: 0.0,
        pixels: terms.len(),
    }
}

/// The rays through a [`GRID`]² grid of `view`'s pixels, each at `offset(pixel)` within
/// its pixel (`(0.5, 0.5)`: the centre).
pub fn grid_rays(view: &EyeView, offset: impl Fn(usize) -> Vec2) -> Vec<Ray> {
    let (w, h) = (view.wall.size.width, view.wall.size.height);
    let (gx, gy) = (GRID.min(w), GRID.min(h));
    (0..gy)
        .flat_map(|j| (0..gx).map(move |i| (i, j)))
        .enumerate()
        .map(|(k, (i, j))| {
            let x = ((i as f32 + 0.5) * w as f32 / gx as f32).floor();
            let y = ((j as f32 + 0.5) * h as f32 / gy as f32).floor();
            view.wall.ray(Vec2::new(x, y) + offset(k))
        })
        .collect()
}

/// Measures `k` on `view` from the field's values along the grid's rays (through the
/// pixels' centres, as a wall's lookups) and [`PER_PIXEL`] samples of each pixel made by
/// `sample` (a batch of rays and a stream) through random points of it, as the feeds
/// take them: the field's error includes what one ray per pixel misses at edges.
pub fn measure(
    view: &EyeView,
    field: impl Fn(&[Ray], u32) -> Vec<Vec3>,
    sample: impl Fn(&[Ray], u64) -> Vec<Vec3>,
) -> Measured {
    let centres = grid_rays(view, |_| Vec2::splat(0.5));
    let v = field(&centres, MEASURED_ESTIMATES);
    let few = field(&centres, FEW_ESTIMATES);
    let mut per_pixel = vec![Vec::with_capacity(PER_PIXEL as usize); v.len()];
    let mut rng = SmallRng::seed_from_u64(0x5EED);
    for k in 0..PER_PIXEL {
        let offsets: Vec<Vec2> = (0..v.len())
            .map(|_| Vec2::new(rng.random(), rng.random()))
            .collect();
        let rays = grid_rays(view, |i| offsets[i]);
        let seed = 0x5EED_0000_0000 ^ (u64::from(k) << 20);
        for (p, s) in per_pixel.iter_mut().zip(sample(&rays, seed)) {
            p.push(s);
        }
    }
    let measured = from_samples(&v, &per_pixel);
    Measured {
        direct_share: direct_share(
            from_samples(&few, &per_pixel).bias2,
            measured.bias2,
            measured.variance / f64::from(measured.samples),
        ),
        ..measured
    }
}

/// The share of the squared error `k` stands for (`stands_for`, `σ²/k`: the measured
/// `b²(16)`, or the least the measure resolves where that is below it) that is the direct
/// light's noise, from the squared errors of the field with [`FEW_ESTIMATES`] (`few`) and
/// with [`MEASURED_ESTIMATES`] (`measured`) in its direct light's mean: `b²(m) = b_f² +
/// σ_d²/m` gives `σ_d² = (b²(4) − b²(16)) / (1/4 − 1/16)`. 0 where the fewer estimates
/// measure no worse.
fn direct_share(few: f64, measured: f64, stands_for: f64) -> f32 {
    let (a, b) = (
        1.0 / f64::from(FEW_ESTIMATES),
        1.0 / f64::from(MEASURED_ESTIMATES),
    );
    if stands_for <= 0.0 || few <= measured {
        return 0.0;
    }
    let noise = (few - measured) / (a - b);
    (noise * b / stands_for).clamp(0.0, 1.0) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The field's squared error with 4 and 16 direct estimates, `b_f² + σ_d²/m`, splits
    /// into the rest's and the direct light's noise, and a pixel's samples count by its
    /// own estimates: as much as measured at 16, less as its mean grows, more below.
    #[test]
    fn the_direct_lights_noise_is_told_from_the_rest_and_falls_with_the_estimates() {
        let (rest, noise) = (0.01f64, 0.16f64);
        let b2 = |m: f64| rest + noise / m;
        let share = direct_share(b2(4.0), b2(16.0), b2(16.0));
        assert!((share - 0.5).abs() < 1e-6, "{share}");
        // Where `k` stands for a larger error than measured (the least the measure
        // resolves), the direct light's noise is a smaller share of it.
        let unresolved = direct_share(b2(4.0), b2(16.0), 2.0 * b2(16.0));
        assert!((unresolved - 0.25).abs() < 1e-6, "{unresolved}");
        let measured = Measured {
            samples: 100.0,
            variance: 1.0,
            bias2: b2(16.0),
            spread: 0.0,
            direct_share: share,
            pixels: 1,
        };
        for m in [1u32, 4, 16, 64, 300] {
            let want = (b2(f64::from(m)) / b2(16.0)) as f32;
            let got = measured.worth_at(m);
            assert!(
                (got - want).abs() < 1e-5 * want,
                "{m}: {got} against {want}"
            );
        }
        // A pixel without direct light: as measured.
        assert_eq!(measured.worth_at(0), 1.0);
        // Nothing to tell: the fewer estimates no worse, or no error at all.
        assert_eq!(direct_share(b2(16.0), b2(16.0), b2(16.0)), 0.0);
        assert_eq!(direct_share(b2(4.0), b2(16.0), 0.0), 0.0);
        assert_eq!(
            Measured {
                direct_share: 0.0,
                ..measured
            }
            .worth_at(300),
            1.0
        );
    }

    /// Pixels whose samples have a known variance about a known mean, and a field off by a
    /// known amount: the measured `k` is `σ² / b²` within the sampling error of its parts.
    #[test]
    fn measures_the_ratio_of_variance_to_squared_bias() {
        let mut rng = SmallRng::seed_from_u64(7);
        let (mu, sigma, bias) = (1.0f32, 0.3f32, 0.05f32);
        // As measured: GRID² pixels, PER_PIXEL samples each.
        let (pixels, m) = ((GRID * GRID) as usize, PER_PIXEL);
        let field = vec![Vec3::splat(mu + bias); pixels];
        let samples: Vec<Vec<Vec3>> = (0..pixels)
            .map(|_| {
                (0..m)
                    .map(|_| {
                        // Uniform with standard deviation sigma.
                        let u: f32 = rng.random::<f32>() - 0.5;
                        Vec3::splat(mu + u * sigma * 12f32.sqrt())
                    })
                    .collect()
            })
            .collect();
        let got = from_samples(&field, &samples);
        let want = sigma * sigma / (bias * bias);
        // b² is estimated as (C̄ − V)² − s²/m: per pixel C̄ − V has the standard deviation
        // σ/√m, so (C̄ − V)² has about 2 b σ/√m, and its mean over the pixels 2 b σ/√m/√pixels
        // (4.7 % of b² here); s² is within 1 %. Three standard errors: 15 %.
        assert!(
            (got.samples - want).abs() < 0.15 * want,
            "{got}: want {want}"
        );
        // The spread: σ² over the field's square (the larger of the two) plus 0.01. Each
        // pixel's s² from 256 samples is within √(2/255) = 9 % (less for a uniform), the
        // mean over 256 pixels within 0.6 %: three standard errors, 2 %.
        let spread = sigma * sigma / ((mu + bias).powi(2) + 0.01);
        assert!(
            (got.spread - spread).abs() < 0.02 * spread,
            "{got}: the spread {} against {spread}",
            got.spread
        );
    }

    /// A field that agrees with the samples' mean is worth the most; one far off, the least.
    #[test]
    fn an_exact_field_is_worth_the_most_and_a_wrong_one_the_least() {
        let samples: Vec<Vec<Vec3>> = (0..100)
            .map(|i| {
                let d = if i % 2 == 0 { 0.1 } else { -0.1 };
                vec![Vec3::splat(1.0 + d), Vec3::splat(1.0 - d)]
            })
            .collect();
        let exact = from_samples(&vec![Vec3::ONE; 100], &samples);
        assert_eq!(exact.samples, MEASURED_RANGE.1, "{exact}");
        let wrong = from_samples(&vec![Vec3::splat(100.0); 100], &samples);
        assert_eq!(wrong.samples, MEASURED_RANGE.0, "{wrong}");
    }

    #[test]
    fn priors_parse_and_a_wrong_one_says_what_to_give() {
        assert_eq!("auto".parse::<Prior>(), Ok(Prior::Measured));
        assert_eq!("256".parse::<Prior>(), Ok(Prior::Samples(256.0)));
        assert_eq!("0".parse::<Prior>(), Ok(Prior::Samples(0.0)));
        for bad in ["-1", "NaN", "inf", "lots"] {
            let e = bad.parse::<Prior>().unwrap_err();
            assert!(e.contains("auto") && e.contains(bad), "{e}");
        }
    }
}
