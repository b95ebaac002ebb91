//! Pacing: the frame period the cluster really runs at. Under frame lock a frame takes as
//! long as its slowest wall, so when that is longer than the configured period the master
//! sends states no faster than the walls swap them, and predicts each head pose to when
//! its frame will really be shown — one paced period ahead, not one configured period.

use std::time::Duration;

/// Weight of the newest frame in the running mean: about the last ten frames count.
const SMOOTHING: f64 = 0.1;

/// The running estimate of a frame's length (state sent → Swap sent).
#[derive(Clone, Debug)]
pub struct Pacer {
    configured: Duration,
    mean_s: Option<f64>,
}

impl Pacer {
    /// A pacer for a clock at `configured` period.
    pub fn new(configured: Duration) -> Pacer {
        Pacer {
            configured,
            mean_s: None,
        }
    }

    /// One frame took `frame` from its state to its Swap.
    pub fn record(&mut self, frame: Duration) {
        let x = frame.as_secs_f64();
        self.mean_s = Some(match self.mean_s {
            None => x,
            Some(m) => m + SMOOTHING * (x - m),
        });
    }

    /// The period the cluster runs at: the configured one, or the walls' if longer.
    pub fn period(&self) -> Duration {
        self.mean_s.map_or(self.configured, |m| {
            self.configured.max(Duration::from_secs_f64(m))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_walls_keep_the_configured_rate_and_slow_ones_set_theirs() {
        let period = Duration::from_millis(16);
        let mut p = Pacer::new(period);
        assert_eq!(p.period(), period);
        for _ in 0..100 {
            p.record(Duration::from_millis(5));
        }
        assert_eq!(p.period(), period, "never faster than configured");
        for _ in 0..100 {
            p.record(Duration::from_millis(40));
        }
        // After n frames at 40 ms the mean is within 35 ms · 0.9^n of it.
        let off = p.period().as_secs_f64() - 0.040;
        assert!(off.abs() < 0.035 * 0.9f64.powi(100) + 1e-9, "{off}");
    }
}
