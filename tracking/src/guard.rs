//! The sample guard: bad input never stops the CAVE. Every sample passes through here
//! before it reaches a filter; NaN or infinite values, quaternions that are not unit,
//! time going backwards and duplicate timestamps are rejected (the consumer holds its
//! last good state), near-unit quaternions are renormalised, and gaps are flagged so
//! that filters restart instead of differentiating across them. All of it is counted.

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::pose::Sample;

/// Thresholds of the guard.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GuardConfig {
    /// A quaternion whose norm differs from 1 by more than this is rejected; a smaller
    /// difference is renormalised.
    pub unit_tolerance: f32,
    /// A sample arriving this long after the previous one marks a gap (filters restart).
    pub gap_ms: f32,
}

impl Default for GuardConfig {
    fn default() -> Self {
        GuardConfig {
            unit_tolerance: 0.01,
            gap_ms: 100.0,
        }
    }
}

/// Why a sample was rejected.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rejection {
    /// A position or quaternion component is NaN or infinite.
    NonFinite,
    /// The quaternion's norm is this far from 1.
    NotUnit { norm: f32 },
    /// The timestamp is this many nanoseconds before the previous accepted one.
    Backwards { by_ns: u64 },
    /// The timestamp equals the previous accepted one.
    Duplicate,
}

impl fmt::Display for Rejection {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Rejection::NonFinite => write!(f, "NaN or infinite value"),
            Rejection::NotUnit { norm } => write!(f, "quaternion norm {norm} is not 1"),
            Rejection::Backwards { by_ns } => write!(f, "time went backwards by {by_ns} ns"),
            Rejection::Duplicate => write!(f, "duplicate timestamp"),
        }
    }
}

/// What the guard made of one sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Checked {
    /// Use this sample (possibly renormalised); `after_gap` asks filters to restart.
    Accepted { sample: Sample, after_gap: bool },
    /// Drop it and hold the last good state.
    Rejected(Rejection),
}

/// Counts of everything the guard saw.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GuardReport {
    pub accepted: u64,
    pub renormalised: u64,
    pub gaps: u64,
    pub non_finite: u64,
    pub not_unit: u64,
    pub backwards: u64,
    pub duplicates: u64,
}

impl GuardReport {
    /// Samples rejected for any reason.
    pub fn rejected(&self) -> u64 {
        self.non_finite + self.not_unit + self.backwards + self.duplicates
    }
}

impl fmt::Display for GuardReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} accepted ({} renormalised, {} after a gap), {} rejected ({} NaN/Inf, {} non-unit quaternion, {} backwards in time, {} duplicate timestamp)",
            self.accepted,
            self.renormalised,
            self.gaps,
            self.rejected(),
            self.non_finite,
            self.not_unit,
            self.backwards,
            self.duplicates
        )
    }
}

/// Checks a stream of samples; see the module documentation.
#[derive(Clone, Debug)]
pub struct SampleGuard {
    config: GuardConfig,
    last_t: Option<u64>,
    report: GuardReport,
}

impl SampleGuard {
    pub fn new(config: GuardConfig) -> Self {
        SampleGuard {
            config,
            last_t: None,
            report: GuardReport::default(),
        }
    }

    /// Checks one sample and counts the outcome.
    pub fn check(&mut self, sample: Sample) -> Checked {
        let rejection = self.find_problem(&sample);
        if let Some(r) = rejection {
            match r {
                Rejection::NonFinite => self.report.non_finite += 1,
                Rejection::NotUnit { .. } => self.report.not_unit += 1,
                Rejection::Backwards { .. } => self.report.backwards += 1,
                Rejection::Duplicate => self.report.duplicates += 1,
            }
            return Checked::Rejected(r);
        }
        let mut sample = sample;
        let norm = sample.pose.orientation.length();
        sample.pose.orientation /= norm;
        // Counted only beyond f32 rounding of values written with ~7 digits.
        if (norm - 1.0).abs() > 1e-5 {
            self.report.renormalised += 1;
        }
        let gap_ns = (self.config.gap_ms.max(0.0) as f64 * 1e6) as u64;
        let after_gap = self.last_t.is_some_and(|last| sample.t_ns - last > gap_ns);
        if after_gap {
            self.report.gaps += 1;
        }
        self.last_t = Some(sample.t_ns);
        self.report.accepted += 1;
        Checked::Accepted { sample, after_gap }
    }

    fn find_problem(&self, s: &Sample) -> Option<Rejection> {
        if !s.pose.is_finite() {
            return Some(Rejection::NonFinite);
        }
        let norm = s.pose.orientation.length();
        let within = (norm - 1.0).abs() <= self.config.unit_tolerance; // false for NaN
        if !within {
            return Some(Rejection::NotUnit { norm });
        }
        match self.last_t {
            Some(last) if s.t_ns < last => Some(Rejection::Backwards {
                by_ns: last - s.t_ns,
            }),
            Some(last) if s.t_ns == last => Some(Rejection::Duplicate),
            _ => None,
        }
    }

    /// The counts so far.
    pub fn report(&self) -> GuardReport {
        self.report
    }
}

impl Default for SampleGuard {
    fn default() -> Self {
        Self::new(GuardConfig::default())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pose::Pose;
    use glam::{Quat, Vec3};

    fn at(t_ms: u64, q: Quat) -> Sample {
        Sample::new(t_ms * 1_000_000, Pose::new(Vec3::new(0.0, 1.7, 0.0), q))
    }

    #[test]
    fn every_kind_of_bad_sample_is_counted_and_rejected() {
        let mut g = SampleGuard::default();
        let ok = Quat::IDENTITY;
        let inputs = [
            at(0, ok),
            at(10, Quat::from_xyzw(f32::NAN, 0.0, 0.0, 1.0)),
            at(20, Quat::from_xyzw(0.0, 0.0, 0.0, 2.0)),
            at(20, Quat::from_xyzw(0.0, 0.0, 0.0, 0.0)),
            at(30, Quat::from_xyzw(0.0, 0.0, 0.0, 1.005)),
            at(25, ok),
            at(30, ok),
            at(500, ok),
        ];
        let results: Vec<Checked> = inputs.iter().map(|&s| g.check(s)).collect();
        assert!(matches!(
            results[0],
            Checked::Accepted {
                after_gap: false,
                ..
            }
        ));
        assert_eq!(results[1], Checked::Rejected(Rejection::NonFinite));
        assert!(matches!(
            results[2],
            Checked::Rejected(Rejection::NotUnit { .. })
        ));
        assert!(matches!(
            results[3],
            Checked::Rejected(Rejection::NotUnit { .. })
        ));
        match results[4] {
            Checked::Accepted { sample, .. } => {
                assert!((sample.pose.orientation.length() - 1.0).abs() < 1e-6)
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(
            results[5],
            Checked::Rejected(Rejection::Backwards { by_ns: 5_000_000 })
        );
        assert_eq!(results[6], Checked::Rejected(Rejection::Duplicate));
        assert!(matches!(
            results[7],
            Checked::Accepted {
                after_gap: true,
                ..
            }
        ));
        let r = g.report();
        assert_eq!((r.accepted, r.renormalised, r.gaps), (3, 1, 1));
        assert_eq!(
            (r.non_finite, r.not_unit, r.backwards, r.duplicates),
            (1, 2, 1, 1)
        );
        assert!(r.to_string().contains("5 rejected"));
    }
}
