//! Tracker sources behind one interface, chosen by a source string:
//! `vrpn://DEVICE@HOST[:PORT][#SENSOR]`, `file:PATH` (CSV, or a `.vrpn` log with
//! `file:PATH.vrpn[#DEVICE[:SENSOR]]`, default `Tracker0` sensor 0) or `synthetic:NAME`.
//! Recorded and synthetic sources play in real time or as fast as possible.

use std::path::PathBuf;
use std::str::FromStr;
use std::time::{Duration, Instant};

use crate::csv_log::{CsvError, TimeUnit, read_csv};
use crate::pose::Sample;
use crate::synthetic::Motion;
use crate::vrpn::{ClientOptions, VrpnClient, VrpnEvent, VrpnTarget};
use crate::vrpn_log::{VrpnLogError, read_vrpn_log};
use crate::vrpn_wire::TrackerSelector;

/// Rate of synthetic sources.
pub const SYNTHETIC_RATE_HZ: f64 = 120.0;

/// A parsed source string.
#[derive(Clone, Debug, PartialEq)]
pub enum SourceSpec {
    Vrpn(VrpnTarget),
    Csv(PathBuf),
    VrpnLog(PathBuf, TrackerSelector),
    Synthetic(Motion),
}

impl FromStr for SourceSpec {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if let Some(rest) = s.strip_prefix("vrpn://") {
            return rest.parse().map(SourceSpec::Vrpn);
        }
        if let Some(name) = s.strip_prefix("synthetic:") {
            return name.parse().map(SourceSpec::Synthetic);
        }
        if let Some(path) = s.strip_prefix("file:") {
            let (path, select) = match path.split_once(".vrpn#") {
                Some((p, sel)) => (format!("{p}.vrpn"), Some(sel)),
                None => (path.to_owned(), None),
            };
            if !path.ends_with(".vrpn") {
                return Ok(SourceSpec::Csv(path.into()));
            }
            let (device, sensor) = match select.map(|s| s.split_once(':').unwrap_or((s, "0"))) {
                Some((d, n)) => (
                    d,
                    n.parse()
                        .map_err(|_| format!("sensor `{n}` in `{s}` is not an integer"))?,
                ),
                None => ("Tracker0", 0),
            };
            return Ok(SourceSpec::VrpnLog(
                path.into(),
                TrackerSelector {
                    device: device.to_owned(),
                    sensor,
                },
            ));
        }
        Err(format!(
            "source `{s}` is not vrpn://DEVICE@HOST[:PORT][#SENSOR], file:PATH or synthetic:NAME"
        ))
    }
}

/// How recorded and synthetic sources are played.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pacing {
    RealTime,
    AsFastAsPossible,
}

/// A source could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum SourceError {
    #[error(transparent)]
    Csv(#[from] CsvError),
    #[error(transparent)]
    VrpnLog(#[from] VrpnLogError),
    #[error(transparent)]
    Session(#[from] crate::session_log::SessionError),
}

/// What a source has next.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Next {
    /// A sample and when it arrived on this machine: stamped by the source's reader (for
    /// VRPN, as the message is read off the socket), so latency is measured from there,
    /// not from when a frame loop got round to it.
    Sample(Sample, Instant),
    /// Nothing arrived before the deadline.
    Idle,
    /// The source has no more samples.
    End,
}

/// A stream of raw samples (bad ones included: the pipeline's guard deals with them).
pub trait TrackerSource {
    /// The next sample, waiting until `deadline` at most.
    fn next(&mut self, deadline: Instant) -> Next;
    /// True for sources that never end by themselves (VRPN, synthetic).
    fn endless(&self) -> bool;
}

/// Opens a source. `unit` forces the time unit of CSV logs.
pub fn open(
    spec: &SourceSpec,
    pacing: Pacing,
    unit: Option<TimeUnit>,
) -> Result<Box<dyn TrackerSource>, SourceError> {
    Ok(match spec {
        SourceSpec::Vrpn(target) => Box::new(VrpnSource(VrpnClient::spawn(
            target.clone(),
            ClientOptions::default(),
        ))),
        SourceSpec::Csv(path) if is_session_file(path) => {
            // A session log is read strictly: a garbage row is an error naming it.
            let log = crate::session_log::read_session(path)?;
            Box::new(Replay::new(log.head, pacing))
        }
        SourceSpec::Csv(path) => {
            let log = read_csv(path, unit)?;
            if log.malformed_count > 0 {
                tracing::warn!(
                    "{}: skipped {} malformed lines, first: {:?}",
                    path.display(),
                    log.malformed_count,
                    log.malformed
                );
            }
            Box::new(Replay::new(log.samples, pacing))
        }
        SourceSpec::VrpnLog(path, selector) => {
            let log = read_vrpn_log(path, selector)?;
            if let Some(at) = log.truncated_at {
                tracing::warn!(
                    "{}: truncated at byte {at}; replaying what came before",
                    path.display()
                );
            }
            Box::new(Replay::new(log.samples, pacing))
        }
        SourceSpec::Synthetic(m) => Box::new(Synthetic {
            motion: *m,
            i: 0,
            pacing,
            start: None,
        }),
    })
}

/// True when `path` reads as a session log (unreadable files are left to the CSV reader,
/// which names the problem).
fn is_session_file(path: &std::path::Path) -> bool {
    std::fs::read_to_string(path).is_ok_and(|t| crate::session_log::is_session(&t))
}

/// Plays a list of samples.
pub struct Replay {
    samples: std::vec::IntoIter<Sample>,
    pacing: Pacing,
    start: Option<(Instant, u64)>,
    pending: Option<Sample>,
}

impl Replay {
    pub fn new(samples: Vec<Sample>, pacing: Pacing) -> Self {
        Replay {
            samples: samples.into_iter(),
            pacing,
            start: None,
            pending: None,
        }
    }
}

/// Waits until `sample` is due in real time and returns when it was due (its arrival), or
/// `None` at the deadline (the caller keeps it pending).
fn pace(start: &mut Option<(Instant, u64)>, sample: Sample, deadline: Instant) -> Option<Instant> {
    let (t0, s0) = *start.get_or_insert((Instant::now(), sample.t_ns));
    let due = t0 + Duration::from_nanos(sample.t_ns.saturating_sub(s0));
    let now = Instant::now();
    if due > now {
        std::thread::sleep(due.min(deadline) - now);
        if due > deadline {
            return None;
        }
    }
    Some(due)
}

impl TrackerSource for Replay {
    fn next(&mut self, deadline: Instant) -> Next {
        let Some(sample) = self.pending.take().or_else(|| self.samples.next()) else {
            return Next::End;
        };
        if self.pacing == Pacing::AsFastAsPossible {
            return Next::Sample(sample, Instant::now());
        }
        match pace(&mut self.start, sample, deadline) {
            Some(due) => Next::Sample(sample, due),
            None => {
                self.pending = Some(sample);
                Next::Idle
            }
        }
    }

    fn endless(&self) -> bool {
        false
    }
}

/// Generates a synthetic motion at [`SYNTHETIC_RATE_HZ`].
struct Synthetic {
    motion: Motion,
    i: u64,
    pacing: Pacing,
    start: Option<(Instant, u64)>,
}

impl TrackerSource for Synthetic {
    fn next(&mut self, deadline: Instant) -> Next {
        let sample = self.motion.sample(self.i, SYNTHETIC_RATE_HZ);
        let arrived = match self.pacing {
            Pacing::RealTime => match pace(&mut self.start, sample, deadline) {
                Some(due) => due,
                None => return Next::Idle,
            },
            Pacing::AsFastAsPossible => Instant::now(),
        };
        self.i += 1;
        Next::Sample(sample, arrived)
    }

    fn endless(&self) -> bool {
        true
    }
}

/// Samples from a live VRPN server; connection trouble is logged and the client retries.
struct VrpnSource(VrpnClient);

impl TrackerSource for VrpnSource {
    fn next(&mut self, deadline: Instant) -> Next {
        loop {
            let wait = deadline.saturating_duration_since(Instant::now());
            match self.0.recv_timeout(wait) {
                Ok(VrpnEvent::Sample(s, at)) => return Next::Sample(s, at),
                Ok(VrpnEvent::Connected { addr }) => {
                    tracing::info!("connected to VRPN server {addr}")
                }
                Ok(VrpnEvent::Disconnected(e)) => tracing::warn!("{e}"),
                // A tracker client reports no input events.
                Ok(VrpnEvent::Input(..)) => {}
                Err(_) => return Next::Idle,
            }
        }
    }

    fn endless(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn source_strings_parse() {
        let v: SourceSpec = "vrpn://Tracker0@localhost:3883#1".parse().unwrap();
        assert!(matches!(v, SourceSpec::Vrpn(t) if t.sensor == 1 && t.port == 3883));
        assert_eq!(
            "file:a/b.csv".parse(),
            Ok(SourceSpec::Csv("a/b.csv".into()))
        );
        assert_eq!(
            "file:x.vrpn#Head:2".parse(),
            Ok(SourceSpec::VrpnLog(
                "x.vrpn".into(),
                TrackerSelector {
                    device: "Head".into(),
                    sensor: 2
                }
            ))
        );
        assert_eq!(
            "file:x.vrpn".parse(),
            Ok(SourceSpec::VrpnLog(
                "x.vrpn".into(),
                TrackerSelector {
                    device: "Tracker0".into(),
                    sensor: 0
                }
            ))
        );
        assert_eq!(
            "synthetic:nod".parse(),
            Ok(SourceSpec::Synthetic(Motion::Nod))
        );
        assert!(
            "http://x"
                .parse::<SourceSpec>()
                .unwrap_err()
                .contains("synthetic:NAME")
        );
    }

    #[test]
    fn fast_replay_yields_everything_then_ends() {
        let samples = Motion::Walk.samples(60.0, 1.0);
        let mut r = Replay::new(samples.clone(), Pacing::AsFastAsPossible);
        let far = Instant::now() + Duration::from_secs(60);
        for s in &samples {
            assert!(matches!(r.next(far), Next::Sample(x, _) if x == *s));
        }
        assert_eq!(r.next(far), Next::End);
    }

    #[test]
    fn real_time_replay_holds_a_sample_that_is_not_due() {
        let samples = vec![
            Motion::Still.sample(0, 1.0),
            Motion::Still.sample(3600, 1.0),
        ];
        let mut r = Replay::new(samples.clone(), Pacing::RealTime);
        assert!(matches!(r.next(Instant::now()), Next::Sample(x, _) if x == samples[0]));
        assert_eq!(r.next(Instant::now()), Next::Idle, "an hour early");
        assert_eq!(r.pending, Some(samples[1]));
    }
}
