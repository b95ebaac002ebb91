//! The head-tracking pipeline the master runs: guard → hemisphere continuity → One Euro
//! filter (optional) → predictor. Rejected samples leave the state as it was (the last
//! good pose is held); a gap restarts the filter and the predictor.

use crate::guard::{Checked, GuardReport, SampleGuard};
use crate::hemisphere::Hemisphere;
use crate::one_euro::OneEuroPose;
use crate::params::TrackingParams;
use crate::pose::{Pose, Sample};
use crate::predict::{Predictor, PredictorKind};

/// Raw tracker samples in, predicted poses out.
#[derive(Clone, Debug)]
pub struct HeadTracker {
    guard: SampleGuard,
    hemisphere: Hemisphere,
    filter: Option<OneEuroPose>,
    predictor: Predictor,
}

impl HeadTracker {
    /// A pipeline with the configured predictor.
    pub fn new(params: &TrackingParams) -> Self {
        Self::with_predictor(params, params.prediction.method)
    }

    /// A pipeline with the given predictor and the other settings from `params`.
    pub fn with_predictor(params: &TrackingParams, kind: PredictorKind) -> Self {
        let f = params.filter;
        let p = params.prediction;
        HeadTracker {
            guard: SampleGuard::new(params.guard),
            hemisphere: Hemisphere::new(),
            filter: f
                .enabled
                .then(|| OneEuroPose::new(f.position, f.orientation)),
            predictor: Predictor::new(kind, p.constant_velocity, p.desp),
        }
    }

    /// Feeds one raw sample; says what the guard made of it.
    pub fn push(&mut self, sample: Sample) -> Checked {
        let checked = self.guard.check(sample);
        if let Checked::Accepted {
            mut sample,
            after_gap,
        } = checked
        {
            if after_gap {
                self.hemisphere.reset();
                self.predictor.reset();
                if let Some(f) = &mut self.filter {
                    f.reset();
                }
            }
            sample.pose.orientation = self.hemisphere.align(sample.pose.orientation);
            if let Some(f) = &mut self.filter {
                sample = f.filter(sample);
            }
            self.predictor.update(sample);
        }
        checked
    }

    /// The pose expected at `t_ns` (the frame's display time); `None` before any good sample.
    pub fn predict(&self, t_ns: u64) -> Option<Pose> {
        self.predictor.predict(t_ns)
    }

    /// What the guard counted.
    pub fn report(&self) -> GuardReport {
        self.guard.report()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::Motion;
    use glam::Quat;

    #[test]
    fn bad_samples_are_held_over_and_never_reach_the_output() {
        let mut params = TrackingParams::default();
        params.filter.enabled = true;
        let mut t = HeadTracker::new(&params);
        let samples = Motion::Turn.samples(100.0, 1.0);
        for (i, s) in samples.iter().enumerate() {
            let mut s = *s;
            match i % 10 {
                3 => s.pose.position.x = f32::NAN,
                5 => s.pose.orientation = Quat::from_xyzw(0.0, 0.0, 0.0, 0.0),
                7 => s.pose.orientation = -s.pose.orientation, // a flip: fine
                _ => {}
            }
            t.push(s);
            if i % 10 == 8 {
                t.push(s); // duplicate
            }
            let p = t.predict(s.t_ns + 50_000_000).unwrap();
            assert!(p.is_finite() && (p.orientation.length() - 1.0).abs() < 1e-4);
        }
        let r = t.report();
        assert_eq!((r.non_finite, r.not_unit, r.duplicates), (10, 10, 10));
    }
}
