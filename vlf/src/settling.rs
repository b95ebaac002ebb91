//! When a pixel's running mean of the direct light needs no new estimate: work in
//! proportion to what changed, as the render cache spends its samples where the image
//! needs them (`papers/render-cache.md` §4).
//!
//! A pixel keeps, beside the sum of its estimates, the spread of its frames' means
//! ([`Spread`]): each frame's new estimates are one batch, and the batches' scatter about
//! the running mean estimates one estimate's variance `σ²`. Its mean has the standard
//! error `σ / √n` after `n` estimates. The mean is *settled* when that error is below
//! [`Settling::tolerance`] of the pixel's value: a sunlit or shadowed point settles after
//! its first frames (every sample of the sun's disc agrees), a penumbra or an area lamp's
//! light goes on taking an estimate a frame until its error is below the tolerance. The
//! tolerance is relative, with no floor in the scene's units (the relative MSE's `+ 0.01`
//! would settle every pixel of a dim scene at once: its walls are exposed to show it). A settled pixel takes none,
//! but for one every [`Settling::refresh`] frames (staggered across the pixels), so that
//! a mean whose first batches agreed by chance (a penumbra's edge that the first samples
//! all missed) is found out. A pixel that sees a new point starts again, unsettled.

use crate::pixel_direct::Estimate;

/// The spread of a pixel's frames' means: the sum over its frames `f` of `k_f · x_f²`,
/// `x_f` the luminance of the mean of that frame's `k_f` estimates, and how many frames.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Spread {
    squares: f32,
    frames: u32,
}

impl Spread {
    /// Adds a frame whose `take` estimates summed to the luminance `sum` (the running
    /// sum's luminance before and after them differs by it).
    pub fn add(&mut self, sum: f32, take: u32) {
        if take == 0 {
            return;
        }
        let x = sum / take as f32;
        self.squares += take as f32 * x * x;
        self.frames += 1;
    }

    /// The variance of one estimate, from a mean of `count` estimates summing to the
    /// luminance `sum`: the frames' weighted scatter about the mean, `Σ k_f (x_f − μ)² =
    /// Σ k_f x_f² − S²/n`, over its `F − 1` degrees of freedom; `None` with fewer than
    /// two frames.
    fn variance(&self, sum: f32, count: u32) -> Option<f32> {
        if self.frames < 2 || count == 0 {
            return None;
        }
        let scatter = self.squares - sum * sum / count as f32;
        Some(scatter.max(0.0) / (self.frames - 1) as f32)
    }
}

/// The rule by which a pixel's mean is settled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settling {
    /// The standard error of a settled mean, relative to its value: `σ² / n ≤
    /// tolerance² μ²`.
    pub tolerance: f32,
    /// The frames a mean is judged on before it may settle.
    pub min_frames: u32,
    /// A settled pixel takes one estimate every this many frames.
    pub refresh: u32,
}

impl Settling {
    /// The walls' rule. A tolerance of 2 %: a settled pixel's squared error, 4·10⁻⁴ of its
    /// value's, is a third of the converged references' own noise (the room's floor wall
    /// at 1.1·10⁻³, `docs/performance/compare.md`). Four frames, the first frame's
    /// estimates one of them, before a mean is judged; a settled pixel looks again every
    /// 16 frames (a sixteenth of the pixels a frame).
    pub const WALLS: Settling = Settling {
        tolerance: 0.02,
        min_frames: 4,
        refresh: 16,
    };

    /// Whether the mean of `count` estimates summing to `sum`, spread as `spread`, is
    /// settled.
    pub fn settled(&self, sum: &Estimate, count: u32, spread: &Spread) -> bool {
        if spread.frames < self.min_frames {
            return false;
        }
        let s = luminance(sum);
        let Some(variance) = spread.variance(s, count) else {
            return false;
        };
        let mean = s / count as f32;
        variance / count as f32 <= self.tolerance * self.tolerance * mean * mean
    }

    /// Whether pixel `pixel`, settled, takes an estimate in frame `frame`.
    pub fn refreshes(&self, pixel: usize, frame: u64) -> bool {
        (frame + pixel as u64).is_multiple_of(u64::from(self.refresh.max(1)))
    }
}

/// The Rec. 709 luminance of an estimate's radiance.
pub fn luminance(e: &Estimate) -> f32 {
    e.radiance.dot(glam::Vec3::new(0.2126, 0.7152, 0.0722))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn grey(y: f32) -> Estimate {
        Estimate {
            radiance: Vec3::splat(y),
            ..Estimate::default()
        }
    }

    /// Frames that all agree settle once there are enough of them; frames that scatter
    /// settle only when the mean's standard error is within the tolerance: `σ² / n`
    /// against `tolerance² μ²`, here σ = 1, μ = 10, so at n ≥ 25 for 2 %.
    #[test]
    fn a_mean_settles_when_its_standard_error_is_within_the_tolerance() {
        let rule = Settling::WALLS;
        let mut sum = Estimate::default();
        let mut spread = Spread::default();
        for n in 1..=8u32 {
            sum += grey(3.0);
            spread.add(3.0, 1);
            assert_eq!(rule.settled(&sum, n, &spread), n >= rule.min_frames, "{n}");
        }
        // Alternating 9 and 11: one estimate's variance is 1 (up to n/(n − 1)).
        let (mut sum, mut spread) = (Estimate::default(), Spread::default());
        let mut first_settled = None;
        for n in 1..=200u32 {
            let x = if n % 2 == 0 { 9.0 } else { 11.0 };
            sum += grey(x);
            spread.add(x, 1);
            if first_settled.is_none() && rule.settled(&sum, n, &spread) {
                first_settled = Some(n);
            }
        }
        let bound = 1.0 / (rule.tolerance * rule.tolerance * 100.0);
        let n = first_settled.expect("settles");
        assert!(
            (n as f32 - bound).abs() <= 2.0,
            "settled after {n} estimates, σ²/(τ² μ²) = {bound}"
        );
    }

    /// A batch of estimates counts as one frame of their mean, weighted by their number:
    /// a first frame of two equal estimates and later frames of one of the same value
    /// scatter by nothing.
    #[test]
    fn batches_weigh_by_their_estimates() {
        let mut spread = Spread::default();
        spread.add(2.0 * 5.0, 2);
        spread.add(5.0, 1);
        spread.add(5.0, 1);
        let v = spread.variance(20.0, 4).unwrap();
        assert!(v.abs() < 1e-5, "variance {v}");
        spread.add(0.0, 0);
        assert_eq!(spread.frames, 3, "a frame without estimates is no frame");
    }

    /// Settled pixels look again one in `refresh` frames, each frame a different
    /// `1/refresh` of them.
    #[test]
    fn settled_pixels_refresh_in_turn() {
        let rule = Settling::WALLS;
        let n = 64;
        for frame in 0..rule.refresh as u64 {
            let taking = (0..n).filter(|&i| rule.refreshes(i, frame)).count();
            assert_eq!(taking, n / rule.refresh as usize);
        }
        let once: Vec<usize> = (0..rule.refresh as u64)
            .map(|f| (0..n).filter(|&i| i == 5 && rule.refreshes(i, f)).count())
            .collect();
        assert_eq!(once.iter().sum::<usize>(), 1);
    }
}
