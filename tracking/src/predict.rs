//! Prediction of the head pose at a frame's display time, from the samples so far.
//!
//! - Constant velocity: the last pose moved on by an exponentially smoothed linear and
//!   angular velocity (smoothing time constant in milliseconds, 0 = raw differences).
//! - LaViola's double exponential smoothing (DESP, IEEE VR 2003): two cascaded
//!   exponential smoothers S and S²; the prediction τ steps ahead is
//!   `(2 + ατ/(1−α))·S − (1 + ατ/(1−α))·S²`, and for orientation its slerp form
//!   `slerp(S², S, 2 + ατ/(1−α))` with S, S² smoothed by slerp. α is given as a time
//!   constant T (α = 1 − e^(−dt/T) per sample of interval dt), so the same parameters hold
//!   at any tracker rate; τ is the look-ahead in (mean) sample intervals.

use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};

use crate::pose::{Pose, Sample, seconds_between};
use crate::rotation::{exp, log, slerp};

/// Which predictor a pipeline uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PredictorKind {
    /// The last pose, unchanged.
    None,
    ConstantVelocity,
    Desp,
}

impl PredictorKind {
    pub const ALL: [PredictorKind; 3] = [
        PredictorKind::None,
        PredictorKind::ConstantVelocity,
        PredictorKind::Desp,
    ];

    pub fn name(self) -> &'static str {
        match self {
            PredictorKind::None => "none",
            PredictorKind::ConstantVelocity => "constant-velocity",
            PredictorKind::Desp => "desp",
        }
    }
}

/// Parameters of the constant-velocity predictor.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConstantVelocityParams {
    /// Time constant (ms) of the exponential smoothing of linear velocity.
    pub position_time_constant_ms: f32,
    /// Time constant (ms) of the exponential smoothing of angular velocity.
    pub orientation_time_constant_ms: f32,
}

/// Parameters of the DESP predictor.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DespParams {
    /// Smoothing time constant (ms) for position.
    pub position_time_constant_ms: f32,
    /// Smoothing time constant (ms) for orientation.
    pub orientation_time_constant_ms: f32,
}

/// `α = 1 − e^(−dt/T)`; `T = 0` means no smoothing (α = 1).
fn alpha(dt: f32, time_constant_ms: f32) -> f32 {
    if time_constant_ms <= 0.0 {
        1.0
    } else {
        1.0 - (-dt * 1000.0 / time_constant_ms).exp()
    }
}

/// Constant-velocity predictor state.
#[derive(Clone, Debug)]
pub struct ConstantVelocity {
    params: ConstantVelocityParams,
    last: Option<Sample>,
    /// Linear velocity, m/s, and angular velocity in the head frame, rad/s.
    velocity: Option<(Vec3, Vec3)>,
}

impl ConstantVelocity {
    pub fn new(params: ConstantVelocityParams) -> Self {
        ConstantVelocity {
            params,
            last: None,
            velocity: None,
        }
    }

    pub fn update(&mut self, s: Sample) {
        if let Some(prev) = self.last {
            let dt = seconds_between(prev.t_ns, s.t_ns);
            if dt <= 0.0 {
                return;
            }
            let v = (s.pose.position - prev.pose.position) / dt;
            let w = log(prev.pose.orientation.conjugate() * s.pose.orientation) / dt;
            self.velocity = Some(match self.velocity {
                None => (v, w),
                Some((v0, w0)) => (
                    v0.lerp(v, alpha(dt, self.params.position_time_constant_ms)),
                    w0.lerp(w, alpha(dt, self.params.orientation_time_constant_ms)),
                ),
            });
        }
        self.last = Some(s);
    }

    pub fn predict(&self, t_ns: u64) -> Option<Pose> {
        let last = self.last?;
        let Some((v, w)) = self.velocity else {
            return Some(last.pose);
        };
        let ahead = seconds_between(last.t_ns, t_ns);
        Some(Pose::new(
            last.pose.position + v * ahead,
            (last.pose.orientation * exp(w * ahead)).normalize(),
        ))
    }
}

/// DESP predictor state.
#[derive(Clone, Debug)]
pub struct Desp {
    params: DespParams,
    state: Option<DespState>,
}

#[derive(Clone, Copy, Debug)]
struct DespState {
    t_ns: u64,
    /// Mean sample interval (s), exponentially averaged; 0 until two samples came.
    dt: f32,
    s_p: Vec3,
    s2_p: Vec3,
    s_q: Quat,
    s2_q: Quat,
}

impl Desp {
    pub fn new(params: DespParams) -> Self {
        Desp {
            params,
            state: None,
        }
    }

    pub fn update(&mut self, s: Sample) {
        let (p, q) = (s.pose.position, s.pose.orientation);
        let Some(st) = &mut self.state else {
            self.state = Some(DespState {
                t_ns: s.t_ns,
                dt: 0.0,
                s_p: p,
                s2_p: p,
                s_q: q,
                s2_q: q,
            });
            return;
        };
        let dt = seconds_between(st.t_ns, s.t_ns);
        if dt <= 0.0 {
            return;
        }
        st.dt = if st.dt == 0.0 {
            dt
        } else {
            st.dt + 0.1 * (dt - st.dt)
        };
        st.t_ns = s.t_ns;
        let a_p = alpha(dt, self.params.position_time_constant_ms);
        let a_q = alpha(dt, self.params.orientation_time_constant_ms);
        st.s_p = st.s_p.lerp(p, a_p);
        st.s2_p = st.s2_p.lerp(st.s_p, a_p);
        st.s_q = slerp(st.s_q, q, a_q);
        st.s2_q = slerp(st.s2_q, st.s_q, a_q);
    }

    pub fn predict(&self, t_ns: u64) -> Option<Pose> {
        let st = self.state?;
        let ahead = seconds_between(st.t_ns, t_ns);
        // ατ/(1−α) with τ = ahead/dt steps; with α = 1 − e^(−dt/T) that is ahead·(e^(dt/T) − 1)/dt.
        let k = |t_ms: f32| {
            if st.dt == 0.0 || t_ms <= 0.0 {
                0.0
            } else {
                ahead * ((st.dt * 1000.0 / t_ms).exp() - 1.0) / st.dt
            }
        };
        let kp = k(self.params.position_time_constant_ms);
        let kq = k(self.params.orientation_time_constant_ms);
        let position = st.s_p * (2.0 + kp) - st.s2_p * (1.0 + kp);
        Some(Pose::new(position, slerp(st.s2_q, st.s_q, 2.0 + kq)))
    }
}

/// Any of the predictors.
#[derive(Clone, Debug)]
pub enum Predictor {
    None(Option<Sample>),
    ConstantVelocity(ConstantVelocity),
    Desp(Desp),
}

impl Predictor {
    pub fn new(kind: PredictorKind, cv: ConstantVelocityParams, desp: DespParams) -> Self {
        match kind {
            PredictorKind::None => Predictor::None(None),
            PredictorKind::ConstantVelocity => {
                Predictor::ConstantVelocity(ConstantVelocity::new(cv))
            }
            PredictorKind::Desp => Predictor::Desp(Desp::new(desp)),
        }
    }

    /// Feeds one (guarded, hemisphere-aligned) sample.
    pub fn update(&mut self, s: Sample) {
        match self {
            Predictor::None(last) => *last = Some(s),
            Predictor::ConstantVelocity(p) => p.update(s),
            Predictor::Desp(p) => p.update(s),
        }
    }

    /// The pose expected at `t_ns`; `None` before the first sample.
    pub fn predict(&self, t_ns: u64) -> Option<Pose> {
        match self {
            Predictor::None(last) => last.map(|s| s.pose),
            Predictor::ConstantVelocity(p) => p.predict(t_ns),
            Predictor::Desp(p) => p.predict(t_ns),
        }
    }

    /// Forgets everything (after a tracking gap), keeping the parameters.
    pub fn reset(&mut self) {
        match self {
            Predictor::None(last) => *last = None,
            Predictor::ConstantVelocity(p) => *p = ConstantVelocity::new(p.params),
            Predictor::Desp(p) => *p = Desp::new(p.params),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rotation::angle_between;

    const CV: ConstantVelocityParams = ConstantVelocityParams {
        position_time_constant_ms: 0.0,
        orientation_time_constant_ms: 0.0,
    };
    const DESP: DespParams = DespParams {
        position_time_constant_ms: 30.0,
        orientation_time_constant_ms: 30.0,
    };

    /// Uniform motion: 0.5 m/s along x, 1 rad/s about y.
    fn uniform(i: u64) -> Sample {
        let t = i as f32 * 0.005;
        Sample::new(
            i * 5_000_000,
            Pose::new(Vec3::new(0.5 * t, 1.7, 0.0), Quat::from_rotation_y(t)),
        )
    }

    #[test]
    fn both_predictors_are_exact_for_uniform_motion() {
        for kind in [PredictorKind::ConstantVelocity, PredictorKind::Desp] {
            let mut p = Predictor::new(kind, CV, DESP);
            for i in 0..400 {
                p.update(uniform(i));
            }
            let truth = uniform(399 + 20); // 100 ms ahead
            let got = p.predict(truth.t_ns).unwrap();
            assert!(
                (got.position - truth.pose.position).length() < 1e-4,
                "{kind:?}: {got:?}"
            );
            assert!(
                angle_between(got.orientation, truth.pose.orientation) < 1e-4,
                "{kind:?}"
            );
        }
    }

    #[test]
    fn no_prediction_holds_and_reset_forgets() {
        let mut p = Predictor::new(PredictorKind::None, CV, DESP);
        assert_eq!(p.predict(0), None);
        p.update(uniform(3));
        assert_eq!(p.predict(1_000_000_000), Some(uniform(3).pose));
        p.reset();
        assert_eq!(p.predict(0), None);
    }

    #[test]
    fn repeated_timestamps_do_not_produce_nan() {
        for kind in PredictorKind::ALL {
            let mut p = Predictor::new(kind, CV, DESP);
            for _ in 0..3 {
                p.update(uniform(7));
            }
            assert!(p.predict(uniform(9).t_ns).unwrap().is_finite());
        }
    }
}
