//! Offline evaluation of predictors on a recorded trace, as in the study the HoloLens
//! traces come from: the trace (guarded, hemisphere-aligned) is resampled to 200 Hz
//! (position linearly, orientation by slerp); at each sample every predictor is fed the
//! sample and asked for the pose one look-ahead later, which is compared with the trace's
//! own pose at that time. Errors: position distance (cm) and the angle between predicted
//! and true rotation (degrees), as mean absolute and root mean square.

use std::fmt::Write as _;

use crate::guard::{Checked, GuardReport, SampleGuard};
use crate::hemisphere::Hemisphere;
use crate::params::TrackingParams;
use crate::pipeline::HeadTracker;
use crate::pose::{Pose, Sample};
use crate::predict::PredictorKind;
use crate::rotation::{angle_between, slerp};

/// The rate traces are resampled to.
pub const EVAL_RATE_HZ: u64 = 200;
const STEP_NS: u64 = 1_000_000_000 / EVAL_RATE_HZ;
/// Samples at the start of a trace that no predictor is scored on (filters settling).
pub const WARMUP: usize = 40;

/// Guarded, hemisphere-aligned samples of a raw trace, with what the guard counted.
pub fn clean(raw: &[Sample]) -> (Vec<Sample>, GuardReport) {
    let mut guard = SampleGuard::default();
    let mut hemi = Hemisphere::new();
    let mut out = Vec::with_capacity(raw.len());
    for &s in raw {
        if let Checked::Accepted { mut sample, .. } = guard.check(s) {
            sample.pose.orientation = hemi.align(sample.pose.orientation);
            out.push(sample);
        }
    }
    (out, guard.report())
}

/// Resamples strictly increasing samples at [`EVAL_RATE_HZ`] from the first sample's time.
pub fn resample(samples: &[Sample]) -> Vec<Sample> {
    let Some((first, last)) = samples.first().zip(samples.last()) else {
        return Vec::new();
    };
    let mut out = Vec::with_capacity(((last.t_ns - first.t_ns) / STEP_NS + 1) as usize);
    let mut j = 0;
    let mut t = first.t_ns;
    while t <= last.t_ns {
        while j + 1 < samples.len() && samples[j + 1].t_ns < t {
            j += 1;
        }
        let (a, b) = (samples[j], samples[(j + 1).min(samples.len() - 1)]);
        let u = if b.t_ns > a.t_ns {
            (t - a.t_ns) as f64 / (b.t_ns - a.t_ns) as f64
        } else {
            0.0
        } as f32;
        let u = u.clamp(0.0, 1.0);
        out.push(Sample::new(
            t,
            Pose::new(
                a.pose.position.lerp(b.pose.position, u),
                slerp(a.pose.orientation, b.pose.orientation, u),
            ),
        ));
        t += STEP_NS;
    }
    out
}

/// Errors of one predictor at one look-ahead.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EvalRow {
    pub lookahead_ms: u32,
    pub predictor: PredictorKind,
    pub pos_mae_cm: f64,
    pub pos_rms_cm: f64,
    pub ang_mae_deg: f64,
    pub ang_rms_deg: f64,
    pub count: usize,
}

/// Scores every predictor at every look-ahead (ms, multiples of 5) on 200 Hz samples.
pub fn evaluate(
    resampled: &[Sample],
    lookaheads_ms: &[u32],
    params: &TrackingParams,
) -> Vec<EvalRow> {
    let mut rows = Vec::new();
    for &la in lookaheads_ms {
        let k = (la as u64 * 1_000_000 / STEP_NS) as usize;
        for kind in PredictorKind::ALL {
            rows.push(score(resampled, la, k, kind, params));
        }
    }
    rows
}

fn score(
    s: &[Sample],
    lookahead_ms: u32,
    k: usize,
    kind: PredictorKind,
    params: &TrackingParams,
) -> EvalRow {
    let mut tracker = HeadTracker::with_predictor(params, kind);
    let (mut n, mut pa, mut p2, mut aa, mut a2) = (0usize, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for i in 0..s.len() {
        tracker.push(s[i]);
        if i < WARMUP || i + k >= s.len() {
            continue;
        }
        let truth = s[i + k];
        let got = tracker.predict(truth.t_ns).expect("a sample was pushed");
        let pe = (got.position - truth.pose.position).length() as f64 * 100.0;
        let ae = (angle_between(got.orientation, truth.pose.orientation) as f64).to_degrees();
        n += 1;
        pa += pe;
        p2 += pe * pe;
        aa += ae;
        a2 += ae * ae;
    }
    let n_f = n.max(1) as f64;
    EvalRow {
        lookahead_ms,
        predictor: kind,
        pos_mae_cm: pa / n_f,
        pos_rms_cm: (p2 / n_f).sqrt(),
        ang_mae_deg: aa / n_f,
        ang_rms_deg: (a2 / n_f).sqrt(),
        count: n,
    }
}

/// The rows as an aligned text table.
pub fn table(rows: &[EvalRow]) -> String {
    let mut out = String::from(
        "look-ahead  predictor          pos MAE cm  pos RMS cm  ang MAE deg  ang RMS deg\n",
    );
    for r in rows {
        let _ = writeln!(
            out,
            "{:>7} ms  {:<17} {:>11.3} {:>11.3} {:>12.3} {:>12.3}",
            r.lookahead_ms,
            r.predictor.name(),
            r.pos_mae_cm,
            r.pos_rms_cm,
            r.ang_mae_deg,
            r.ang_rms_deg
        );
    }
    out
}

/// The CSV header matching [`csv_line`].
pub const CSV_HEADER: &str =
    "log,lookahead_ms,predictor,pos_mae_cm,pos_rms_cm,ang_mae_deg,ang_rms_deg,count";

/// One row as CSV, tagged with the log's name.
pub fn csv_line(log: &str, r: &EvalRow) -> String {
    format!(
        "{log},{},{},{:.5},{:.5},{:.5},{:.5},{}",
        r.lookahead_ms,
        r.predictor.name(),
        r.pos_mae_cm,
        r.pos_rms_cm,
        r.ang_mae_deg,
        r.ang_rms_deg,
        r.count
    )
}

/// For each look-ahead, whether both predictors beat no prediction on position and angle
/// (mean absolute error); the look-aheads where they do not, with what failed.
pub fn failures(rows: &[EvalRow]) -> Vec<String> {
    let mut out = Vec::new();
    for none in rows.iter().filter(|r| r.predictor == PredictorKind::None) {
        for r in rows
            .iter()
            .filter(|r| r.lookahead_ms == none.lookahead_ms && r.predictor != PredictorKind::None)
        {
            // A trace without any motion of a kind has nothing to beat there.
            if r.pos_mae_cm >= none.pos_mae_cm && none.pos_mae_cm > 1e-6 {
                out.push(format!(
                    "{} ms: {} position {:.3} cm ≥ {:.3}",
                    r.lookahead_ms,
                    r.predictor.name(),
                    r.pos_mae_cm,
                    none.pos_mae_cm
                ));
            }
            if r.ang_mae_deg >= none.ang_mae_deg && none.ang_mae_deg > 1e-6 {
                out.push(format!(
                    "{} ms: {} angle {:.3}° ≥ {:.3}",
                    r.lookahead_ms,
                    r.predictor.name(),
                    r.ang_mae_deg,
                    none.ang_mae_deg
                ));
            }
        }
    }
    out
}

/// One grid value of [`tune`] and the relative errors it gave (see [`relative_error`]).
pub type GridRow = (f32, [(f64, f64); 3]);

/// Time constants (ms) tried by [`tune`]. The grid starts at 5 ms (α ≈ 0.63 at 200 Hz)
/// so that both predictors still smooth: without any, velocity estimates amplify the
/// jitter of optical trackers, which the already smoothed headset traces do not show.
pub const TUNE_GRID_MS: [f32; 10] = [5.0, 10.0, 15.0, 20.0, 30.0, 40.0, 60.0, 80.0, 100.0, 150.0];

/// Mean over traces and look-aheads of each predictor's error relative to no prediction
/// (position, angle); lower is better, 1 is no better than not predicting.
pub fn relative_error(
    traces: &[Vec<Sample>],
    lookaheads_ms: &[u32],
    params: &TrackingParams,
) -> [(f64, f64); 3] {
    let mut sum = [(0.0, 0.0); 3];
    let mut n = 0.0;
    for t in traces {
        let rows = evaluate(t, lookaheads_ms, params);
        for chunk in rows.chunks(PredictorKind::ALL.len()) {
            let none = chunk[0];
            for (k, r) in chunk.iter().enumerate() {
                sum[k].0 += r.pos_mae_cm / none.pos_mae_cm.max(1e-12);
                sum[k].1 += r.ang_mae_deg / none.ang_mae_deg.max(1e-12);
            }
            n += 1.0;
        }
    }
    sum.map(|(p, a)| (p / n, a / n))
}

/// A grid search over the predictors' smoothing time constants on resampled traces,
/// minimising the mean relative mean-absolute error. Position and orientation parameters
/// act independently, so each is chosen by its own error. Returns the tuned parameters
/// and, per grid value, the relative errors of constant velocity and DESP.
pub fn tune(
    traces: &[Vec<Sample>],
    lookaheads_ms: &[u32],
    base: &TrackingParams,
) -> (TrackingParams, Vec<GridRow>) {
    let mut table = Vec::new();
    let mut best = *base;
    let mut scores = [f64::INFINITY; 4];
    for g in TUNE_GRID_MS {
        let mut p = *base;
        p.prediction.constant_velocity.position_time_constant_ms = g;
        p.prediction.constant_velocity.orientation_time_constant_ms = g;
        p.prediction.desp.position_time_constant_ms = g;
        p.prediction.desp.orientation_time_constant_ms = g;
        let e = relative_error(traces, lookaheads_ms, &p);
        let candidates = [e[1].0, e[1].1, e[2].0, e[2].1];
        for (slot, value) in candidates.into_iter().enumerate() {
            if value < scores[slot] {
                scores[slot] = value;
                let (cv, desp) = (
                    &mut best.prediction.constant_velocity,
                    &mut best.prediction.desp,
                );
                match slot {
                    0 => cv.position_time_constant_ms = g,
                    1 => cv.orientation_time_constant_ms = g,
                    2 => desp.position_time_constant_ms = g,
                    _ => desp.orientation_time_constant_ms = g,
                }
            }
        }
        table.push((g, e));
    }
    (best, table)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::csv_log::read_csv;
    use crate::synthetic::Motion;
    use std::path::Path;

    #[test]
    fn resampling_hits_the_grid_and_interpolates() {
        let s = Motion::Turn.samples(60.0, 2.0);
        let r = resample(&s);
        assert_eq!(r.len(), 401);
        for (i, x) in r.iter().enumerate() {
            assert_eq!(x.t_ns, i as u64 * STEP_NS);
            let truth = Motion::Turn.pose_at(x.t_ns as f64 * 1e-9);
            assert!(angle_between(x.pose.orientation, truth.orientation).to_degrees() < 0.1);
        }
    }

    #[test]
    fn predictors_beat_no_prediction_on_synthetic_motion() {
        let r = resample(&Motion::Walk.samples(60.0, 10.0));
        let rows = evaluate(&r, &[20, 60, 100], &TrackingParams::default());
        assert_eq!(rows.len(), 9);
        assert!(failures(&rows).is_empty(), "{}", table(&rows));
        assert!(rows.iter().all(|r| r.count > 1800));
    }

    #[test]
    fn predictors_beat_no_prediction_on_the_first_hololens_trace() {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/tracking/pred6dof/1.csv");
        let (clean, report) = clean(&read_csv(&path, None).unwrap().samples);
        assert_eq!(report.rejected(), 0);
        let rows = evaluate(
            &resample(&clean),
            &[20, 40, 60, 80, 100],
            &TrackingParams::default(),
        );
        assert!(
            failures(&rows).is_empty(),
            "{:?}\n{}",
            failures(&rows),
            table(&rows)
        );
        let csv = csv_line("1.csv", &rows[0]);
        assert_eq!(csv.split(',').count(), CSV_HEADER.split(',').count());
    }
}
