//! Recording any source to CSV (`timestamp,x,y,z,qx,qy,qz,qw`, timestamps in ns, preceded
//! by a `# unit: ns` line), as `holocave tracking record` does. Samples pass the guard
//! first, so a recording holds only usable samples; the guard's counts are returned. With
//! a wand, buttons or axes besides the head, the recording is a session log
//! ([`crate::session_log`]): every device's rows in the order they arrived.

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::guard::{Checked, GuardConfig, GuardReport, SampleGuard};
use crate::input_source::{InputSource, NextInput};
use crate::pose::Sample;
use crate::session_log::SessionWriter;
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

/// The devices of a session recording; the head is required.
pub struct SessionSources<'a> {
    pub head: &'a mut dyn TrackerSource,
    pub wand: Option<&'a mut dyn TrackerSource>,
    pub buttons: Option<&'a mut InputSource>,
    pub axes: Option<&'a mut InputSource>,
}

/// What a session recording wrote.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SessionReport {
    pub head: RecordReport,
    pub wand: RecordReport,
    /// Button and axis events written.
    pub inputs: u64,
}

/// How long one poll of a live device waits before the next device's turn.
const POLL: Duration = Duration::from_millis(1);

/// Records every device of `sources` into one session log at `path`, for `seconds` of the
/// head's sample time (and at most that long on the wall clock when a device is live), or
/// until every recorded device ends.
pub fn record_session(
    sources: SessionSources<'_>,
    path: &Path,
    seconds: Option<f64>,
) -> Result<SessionReport, RecordError> {
    let live = sources.head.endless()
        || sources.wand.as_ref().is_some_and(|w| w.endless())
        || sources.buttons.as_ref().is_some_and(|b| b.endless())
        || sources.axes.as_ref().is_some_and(|a| a.endless());
    if seconds.is_none() && live {
        return Err(RecordError::Endless);
    }
    let io = |source| RecordError::Io {
        path: path.to_owned(),
        source,
    };
    let file = std::fs::File::create(path).map_err(io)?;
    let mut out = SessionWriter::new(BufWriter::new(file)).map_err(io)?;
    let limit_ns = seconds.map(|s| (s.max(0.0) * 1e9) as u64);
    let wall_end = seconds.map(|s| Instant::now() + Duration::from_secs_f64(s.max(0.0)));
    let SessionSources {
        head,
        mut wand,
        mut buttons,
        mut axes,
    } = sources;
    let mut head_guard = SampleGuard::new(GuardConfig::default());
    let mut wand_guard = SampleGuard::new(GuardConfig::default());
    let (mut head_written, mut wand_written, mut inputs) = (0, 0, 0);
    // Per device: done, and its first time (the limit counts from there).
    let mut done = [false, wand.is_none(), buttons.is_none(), axes.is_none()];
    let mut first = [None::<u64>; 4];
    let mut over = |k: usize, t: u64| {
        let t0 = *first[k].get_or_insert(t);
        limit_ns.is_some_and(|l| t.saturating_sub(t0) > l)
    };
    while !done.iter().all(|d| *d) && wall_end.is_none_or(|e| Instant::now() < e) {
        let deadline = Instant::now() + POLL;
        if !done[0] {
            match head.next(deadline) {
                Next::Sample(s, _) if over(0, s.t_ns) => done[0] = true,
                Next::Sample(s, _) => {
                    if let Checked::Accepted { sample, .. } = head_guard.check(s) {
                        out.head(&sample).map_err(io)?;
                        head_written += 1;
                    }
                }
                Next::Idle => {}
                Next::End => done[0] = true,
            }
        }
        if let Some(w) = wand.as_deref_mut().filter(|_| !done[1]) {
            match w.next(deadline) {
                Next::Sample(s, _) if over(1, s.t_ns) => done[1] = true,
                Next::Sample(s, _) => {
                    if let Checked::Accepted { sample, .. } = wand_guard.check(s) {
                        out.wand(&sample).map_err(io)?;
                        wand_written += 1;
                    }
                }
                Next::Idle => {}
                Next::End => done[1] = true,
            }
        }
        for (k, source) in [(2, buttons.as_deref_mut()), (3, axes.as_deref_mut())] {
            let Some(source) = source.filter(|_| !done[k]) else {
                continue;
            };
            match source.next(deadline) {
                NextInput::Event(e, _) if over(k, e.t_ns) => done[k] = true,
                NextInput::Event(e, _) => {
                    out.input(&e).map_err(io)?;
                    inputs += 1;
                }
                NextInput::Idle => {}
                NextInput::End => done[k] = true,
            }
        }
    }
    out.finish().map_err(io)?;
    Ok(SessionReport {
        head: RecordReport {
            written: head_written,
            guard: head_guard.report(),
        },
        wand: RecordReport {
            written: wand_written,
            guard: wand_guard.report(),
        },
        inputs,
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
    fn a_session_recording_of_head_wand_buttons_and_axes_reads_back() {
        use crate::input::{InputEvent, InputSample};
        use crate::session_log::read_session;
        use std::collections::VecDeque;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("session.csv");
        let fast = Pacing::AsFastAsPossible;
        let mut head = open(&"synthetic:walk".parse().unwrap(), fast, None).unwrap();
        let mut wand = open(&"synthetic:nod".parse().unwrap(), fast, None).unwrap();
        let press = |t, pressed| InputSample::new(t, InputEvent::Button { index: 0, pressed });
        let events: VecDeque<_> = vec![press(100_000_000, true), press(600_000_000, false)].into();
        let mut buttons = InputSource::Replay(events.clone());
        let axes_events: VecDeque<_> =
            vec![InputSample::new(0, InputEvent::Axes(vec![0.0, 1.0]))].into();
        let mut axes = InputSource::Replay(axes_events);
        let report = record_session(
            SessionSources {
                head: head.as_mut(),
                wand: Some(wand.as_mut()),
                buttons: Some(&mut buttons),
                axes: Some(&mut axes),
            },
            &path,
            Some(1.0),
        )
        .unwrap();
        assert_eq!(
            (report.head.written, report.wand.written, report.inputs),
            (121, 121, 3)
        );
        let log = read_session(&path).unwrap();
        assert_eq!(
            (log.head.len(), log.wand.len(), log.inputs.len()),
            (121, 121, 3)
        );
        let truth = crate::synthetic::Motion::Walk.samples(120.0, 1.0);
        for (a, b) in log.head.iter().zip(&truth) {
            assert_eq!(a.t_ns, b.t_ns);
            assert!((a.pose.position - b.pose.position).length() < 1e-6);
        }
        assert!(log.inputs.contains(&press(600_000_000, false)));
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
