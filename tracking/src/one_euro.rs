//! The One Euro filter (Casiez, Roussel & Vogel, CHI 2012) for tracker jitter: a low-pass
//! filter whose cutoff rises with speed, so a still head is steady and a moving one does
//! not lag. Applied to position (a 3-vector) and to orientation (the quaternion as a
//! 4-vector kept in one hemisphere, renormalised), with speeds taken as vector norms.

use glam::{Quat, Vec3, Vec4};
use serde::{Deserialize, Serialize};

use crate::pose::{Pose, Sample, seconds_between};

/// Filter parameters (one set for position, one for orientation).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OneEuroParams {
    /// Cutoff frequency (Hz) at rest: lower is steadier.
    pub min_cutoff: f32,
    /// How fast the cutoff grows with speed (per unit/s): higher lags less.
    pub beta: f32,
    /// Cutoff (Hz) of the speed estimate.
    pub d_cutoff: f32,
}

fn alpha(cutoff: f32, dt: f32) -> f32 {
    let tau = 1.0 / (std::f32::consts::TAU * cutoff.max(1e-6));
    1.0 / (1.0 + tau / dt)
}

/// One Euro state for a vector of any width.
#[derive(Clone, Copy, Debug)]
struct OneEuro<V> {
    params: OneEuroParams,
    x: V,
    dx: V,
}

impl<V> OneEuro<V>
where
    V: Copy
        + std::ops::Sub<Output = V>
        + std::ops::Add<Output = V>
        + std::ops::Mul<f32, Output = V>,
{
    fn step(&mut self, x: V, dt: f32, norm: impl Fn(V) -> f32) -> V {
        let raw_dx = (x - self.x) * (1.0 / dt);
        let a_d = alpha(self.params.d_cutoff, dt);
        self.dx = self.dx + (raw_dx - self.dx) * a_d;
        let cutoff = self.params.min_cutoff + self.params.beta * norm(self.dx);
        let a = alpha(cutoff, dt);
        self.x = self.x + (x - self.x) * a;
        self.x
    }
}

/// One Euro filtering of whole poses.
#[derive(Clone, Debug)]
pub struct OneEuroPose {
    position: OneEuroParams,
    orientation: OneEuroParams,
    state: Option<(u64, OneEuro<Vec3>, OneEuro<Vec4>)>,
}

impl OneEuroPose {
    pub fn new(position: OneEuroParams, orientation: OneEuroParams) -> Self {
        OneEuroPose {
            position,
            orientation,
            state: None,
        }
    }

    /// Filters one sample; its quaternion must be in the hemisphere of the previous one.
    pub fn filter(&mut self, s: Sample) -> Sample {
        let q = Vec4::from(s.pose.orientation);
        let Some((t, p, o)) = &mut self.state else {
            self.state = Some((
                s.t_ns,
                OneEuro {
                    params: self.position,
                    x: s.pose.position,
                    dx: Vec3::ZERO,
                },
                OneEuro {
                    params: self.orientation,
                    x: q,
                    dx: Vec4::ZERO,
                },
            ));
            return s;
        };
        let dt = seconds_between(*t, s.t_ns);
        if dt <= 0.0 {
            return Sample::new(s.t_ns, Pose::new(p.x, Quat::from_vec4(o.x).normalize()));
        }
        *t = s.t_ns;
        let position = p.step(s.pose.position, dt, Vec3::length);
        // |dq/dt| is half the angular speed in rad/s.
        let orientation = Quat::from_vec4(o.step(q, dt, |v| 2.0 * v.length())).normalize();
        Sample::new(s.t_ns, Pose::new(position, orientation))
    }

    /// Forgets the state (after a gap).
    pub fn reset(&mut self) {
        self.state = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::Motion;

    const P: OneEuroParams = OneEuroParams {
        min_cutoff: 1.0,
        beta: 1.0,
        d_cutoff: 1.0,
    };

    #[test]
    fn jitter_is_reduced_when_still() {
        let mut f = OneEuroPose::new(P, P);
        let mut raw_err = 0.0;
        let mut filt_err = 0.0;
        let mut state = 12345u32;
        for s in Motion::Still.samples(120.0, 5.0) {
            state = state.wrapping_mul(1664525).wrapping_add(1013904223);
            let noise = (state >> 8) as f32 / (1u32 << 24) as f32 - 0.5;
            let mut noisy = s;
            noisy.pose.position.x += 0.002 * noise;
            let out = f.filter(noisy);
            raw_err += (noisy.pose.position - s.pose.position).length();
            filt_err += (out.pose.position - s.pose.position).length();
        }
        assert!(filt_err < 0.3 * raw_err, "{filt_err} vs {raw_err}");
    }

    #[test]
    fn speed_raises_the_cutoff_so_fast_motion_lags_less() {
        let samples = Motion::Shake.samples(200.0, 2.0);
        let mean_lag = |beta: f32| {
            let mut f = OneEuroPose::new(P, OneEuroParams { beta, ..P });
            let errs: Vec<f32> = samples
                .iter()
                .map(|&s| {
                    crate::rotation::angle_between(f.filter(s).pose.orientation, s.pose.orientation)
                })
                .collect();
            errs[100..].iter().sum::<f32>() / (errs.len() - 100) as f32
        };
        let (plain, adaptive) = (mean_lag(0.0), mean_lag(5.0));
        assert!(
            adaptive < 0.25 * plain,
            "{} vs {} degrees",
            adaptive.to_degrees(),
            plain.to_degrees()
        );
    }
}
