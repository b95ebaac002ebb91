//! Sample warps used by the BSDFs and lights, each with its density.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Cosine-weighted direction on the +Z hemisphere (Malley's method).
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let r = u.x.sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u.x).max(0.0).sqrt())
}

pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) / PI
}

/// Uniform direction in the cone of half-angle `acos(1 − one_minus_cos_max)` around +Z.
/// Taking `1 − cos` rather than the cosine keeps a narrow cone's size exact in f32 (the
/// sun's: `cos` rounds near 1), and `sin θ = √(x (2 − x))` with `x = 1 − cos θ` keeps it
/// for each direction.
pub fn uniform_cone(u: Vec2, one_minus_cos_max: f32) -> Vec3 {
    let x = u.x * one_minus_cos_max;
    let cos_t = 1.0 - x;
    let sin_t = (x * (2.0 - x)).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t)
}

/// Uniform barycentrics `(u, v)` on a triangle (for weights of vertices 1 and 2).
pub fn uniform_triangle(u: Vec2) -> (f32, f32) {
    let s = u.x.sqrt();
    (1.0 - s, u.y * s)
}

/// Whether `x > 0` and finite (false for NaN): the test every density and length passes
/// before it is divided by.
pub fn is_positive_finite(x: f32) -> bool {
    x > 0.0 && x.is_finite()
}

/// Power heuristic (β = 2) weight of strategy `a` against `b`.
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let (a, b) = (pdf_a * pdf_a, pdf_b * pdf_b);
    if a + b > 0.0 && (a + b).is_finite() {
        a / (a + b)
    } else if pdf_a.is_infinite() {
        1.0
    } else {
        0.0
    }
}

/// A piecewise-constant discrete distribution, sampled by binary search on its CDF.
#[derive(Clone, Debug)]
pub struct Distribution {
    cdf: Vec<f32>,
    total: f32,
}

impl Distribution {
    /// From non-negative weights; `None` when they sum to zero (or are not finite).
    pub fn new(weights: &[f32]) -> Option<Self> {
        let mut cdf = Vec::with_capacity(weights.len());
        let mut acc = 0.0f64;
        for w in weights {
            acc += f64::from(w.max(0.0));
            cdf.push(acc as f32);
        }
        let total = acc as f32;
        (total > 0.0 && total.is_finite()).then_some(Self { cdf, total })
    }

    /// An index with probability weight / total.
    pub fn sample(&self, u: f32) -> usize {
        let target = u * self.total;
        self.cdf
            .partition_point(|&c| c <= target)
            .min(self.cdf.len() - 1)
    }

    pub fn probability(&self, i: usize) -> f32 {
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        (self.cdf[i] - lo) / self.total
    }

    /// The cumulative probability of all indices before `i`.
    pub fn cdf_before(&self, i: usize) -> f32 {
        if i == 0 {
            0.0
        } else {
            self.cdf[i - 1] / self.total
        }
    }

    pub fn len(&self) -> usize {
        self.cdf.len()
    }

    /// Always false: a distribution is only made from weights with a positive sum.
    pub fn is_empty(&self) -> bool {
        self.cdf.is_empty()
    }
}

/// For the tests of a choice made per shading point (`few_lights`, `light_groups`): the
/// probabilities of the `count` items sum to one, each sample reports its item's
/// probability, and 100 000 evenly spread samples land in proportion to them (to 1e-3: the
/// spacing of the samples, 1e-5, times the few steps a cumulative sum takes).
#[cfg(test)]
pub(crate) fn check_choice(
    count: usize,
    sample: impl Fn(f32) -> Option<(usize, f32)>,
    probability: impl Fn(usize) -> f32,
    at: &str,
) {
    let total: f32 = (0..count).map(&probability).sum();
    assert!((total - 1.0).abs() < 1e-5, "{at}: {total}");
    let n = 100_000;
    let mut counts = vec![0u32; count];
    for i in 0..n {
        let (k, prob) = sample((i as f32 + 0.5) / n as f32).unwrap();
        assert!((prob - probability(k)).abs() < 1e-6, "{at} {k}");
        counts[k] += 1;
    }
    for (k, c) in counts.iter().enumerate() {
        let f = *c as f32 / n as f32;
        assert!((f - probability(k)).abs() < 1e-3, "{at} {k}: {f}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distribution_samples_in_proportion() {
        let d = Distribution::new(&[1.0, 0.0, 3.0]).unwrap();
        let mut counts = [0usize; 3];
        let n = 40_000;
        for i in 0..n {
            counts[d.sample((i as f32 + 0.5) / n as f32)] += 1;
        }
        assert_eq!(counts[1], 0);
        assert!((counts[0] as f32 / n as f32 - 0.25).abs() < 1e-3);
        assert!((d.probability(2) - 0.75).abs() < 1e-6);
        assert!(Distribution::new(&[0.0, 0.0]).is_none());
        assert!(Distribution::new(&[f32::INFINITY]).is_none());
    }
}
