//! Recording any source to CSV (`timestamp,x,y,z,qx,qy,qz,qw`, timestamps in ns, preceded
//! by a `# unit: ns` line), as `holocave tracking record` does. Samples pass the guard
//! first, so a recording holds only usable samples; the guard's counts are returned.

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::guard::{Checked, GuardConfig, GuardReport, SampleGuard};
use crate::pose::Sample;
use crate::source::{Next, TrackerSource};

/// A recording failed.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    #[error("cannot write recording {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("an endless source (VRPN, synthetic) needs a duration")]
    Endless,
}

/// What was recorded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RecordReport {
    pub written: u64,
    pub guard: GuardReport,
}

/// Writes one sample as a CSV line.
pub fn write_sample(out: &mut impl Write, s: &Sample) -> std::io::Result<()> {
    let (p, q) = (s.pose.position, s.pose.orientation);
    writeln!(
        out,
        "{},{},{},{},{},{},{},{}",
        s.t_ns, p.x, p.y, p.z, q.x, q.y, q.z, q.w
    )
}

/// Records `source` to `path` for `seconds` of sample time (and at most that long on the
/// wall clock when the source is live), or until the source ends.
pub fn record(
    source: &mut dyn TrackerSource,
    path: &Path,
    seconds: Option<f64>,
) -> Result<RecordReport, RecordError> {
    if seconds.is_none() && source.endless() {
        return Err(RecordError::Endless);
    }
    let io = |source| RecordError::Io {
        path: path.to_owned(),
        source,
    };
    let mut out = BufWriter::new(std::fs::File::create(path).map_err(io)?);
    writeln!(out, "# unit: ns\ntimestamp,x,y,z,qx,qy,qz,qw").map_err(io)?;
    let limit_ns = seconds.map(|s| (s.max(0.0) * 1e9) as u64);
    let wall_end = seconds.map(|s| Instant::now() + Duration::from_secs_f64(s.max(0.0)));
    let far = Instant::now() + Duration::from_secs(365 * 24 * 3600);
    let mut guard = SampleGuard::new(GuardConfig::default());
    let mut first = None;
    let mut written = 0;
    loop {
        let sample = match source.next(wall_end.unwrap_or(far)) {
            Next::Sample(s, _) => s,
            Next::Idle if wall_end.is_some_and(|e| Instant::now() >= e) => break,
            Next::Idle => continue,
            Next::End => break,
        };
        let t0 = *first.get_or_insert(sample.t_ns);
        if limit_ns.is_some_and(|l| sample.t_ns.saturating_sub(t0) > l) {
            break;
        }
        if let Checked::Accepted { sample, .. } = guard.check(sample) {
            write_sample(&mut out, &sample).map_err(io)?;
            written += 1;
        }
    }
    out.flush().map_err(io)?;
    Ok(RecordReport {
        written,
        guard: guard.report(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::csv_log::{TimeUnit, read_csv};
    use crate::source::{Pacing, SourceSpec, open};

    #[test]
    fn synthetic_recording_reads_back_exactly_enough() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("nod.csv");
        let mut src = open(
            &"synthetic:nod".parse().unwrap(),
            Pacing::AsFastAsPossible,
            None,
        )
        .unwrap();
        assert!(matches!(
            record(src.as_mut(), &path, None),
            Err(RecordError::Endless)
        ));
        let report = record(src.as_mut(), &path, Some(2.0)).unwrap();
        assert_eq!(report.written, 241);
        let log = read_csv(&path, None).unwrap();
        assert_eq!(log.unit, TimeUnit::Nanoseconds);
        assert_eq!(log.samples.len(), 241);
        let truth = crate::synthetic::Motion::Nod.samples(120.0, 2.0);
        for (a, b) in log.samples.iter().zip(truth.iter()) {
            assert_eq!(a.t_ns, b.t_ns);
            assert!((a.pose.orientation - b.pose.orientation).length() < 1e-6);
        }
    }

    #[test]
    fn bad_samples_in_a_replayed_log_are_dropped_and_counted() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.csv");
        std::fs::write(
            &input,
            "timestamp,x,y,z,qx,qy,qz,qw\n0,0,0,0,0,0,0,1\n10,0,0,0,0,0,0,NaN\n20,0,0,0,0,0,0,1\n15,0,0,0,0,0,0,1\nbad\n30,0,0,0,0,0,0,1\n",
        )
        .unwrap();
        let out = dir.path().join("out.csv");
        let spec: SourceSpec = format!("file:{}", input.display()).parse().unwrap();
        let mut src = open(
            &spec,
            Pacing::AsFastAsPossible,
            Some(TimeUnit::Milliseconds),
        )
        .unwrap();
        let r = record(src.as_mut(), &out, None).unwrap();
        assert_eq!(
            (r.written, r.guard.non_finite, r.guard.backwards),
            (3, 1, 1)
        );
    }
}
