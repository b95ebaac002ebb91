//! Reading CSV tracker logs: `timestamp,x,y,z,qx,qy,qz,qw`, one sample a line, as in the
//! HoloLens traces (whose timestamps are .NET 100 ns ticks) and as `record` writes them.
//!
//! The time unit is detected from the timestamps (or given): absolute epochs are told
//! apart by magnitude (.NET ticks of years 1585..2221 lie in 5e17..7e17, Unix nanoseconds
//! since 2001 above 1e18, Unix micro-, milli- and seconds above 1e15, 1e12, 1e9); relative
//! clocks by their median step, assuming a tracker between 1 Hz and 10 kHz. Times are
//! returned in nanoseconds from the earliest timestamp of the file. Malformed lines are
//! counted and skipped, and the first few are kept with their line numbers for the report.
//! A comment line `# unit: ns` (as `record` writes) states the unit and skips detection.

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use glam::{Quat, Vec3};

use crate::pose::{Pose, Sample};

/// How many malformed lines are kept verbatim in [`CsvLog::malformed`].
pub const KEPT_LINE_ERRORS: usize = 10;

/// The unit of a log's timestamps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeUnit {
    Nanoseconds,
    Microseconds,
    Milliseconds,
    Seconds,
    /// .NET `DateTime` ticks: 100 ns since 0001-01-01.
    DotNetTicks,
}

impl TimeUnit {
    /// Nanoseconds in one unit.
    pub fn ns(self) -> f64 {
        match self {
            TimeUnit::Nanoseconds => 1.0,
            TimeUnit::Microseconds => 1e3,
            TimeUnit::Milliseconds => 1e6,
            TimeUnit::Seconds => 1e9,
            TimeUnit::DotNetTicks => 100.0,
        }
    }
}

impl FromStr for TimeUnit {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "ns" => Ok(TimeUnit::Nanoseconds),
            "us" => Ok(TimeUnit::Microseconds),
            "ms" => Ok(TimeUnit::Milliseconds),
            "s" => Ok(TimeUnit::Seconds),
            "ticks" | "dotnet" => Ok(TimeUnit::DotNetTicks),
            other => Err(format!(
                "unknown time unit `{other}` (expected ns, us, ms, s or ticks)"
            )),
        }
    }
}

impl fmt::Display for TimeUnit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            TimeUnit::Nanoseconds => "ns",
            TimeUnit::Microseconds => "us",
            TimeUnit::Milliseconds => "ms",
            TimeUnit::Seconds => "s",
            TimeUnit::DotNetTicks => ".NET ticks",
        })
    }
}

/// A CSV log could not be read at all.
#[derive(Debug, thiserror::Error)]
pub enum CsvError {
    #[error("cannot read tracker log {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("tracker log {path} has no valid sample line ({malformed} malformed)")]
    Empty { path: PathBuf, malformed: usize },
}

/// One malformed line.
#[derive(Clone, Debug, PartialEq)]
pub struct LineError {
    pub line: usize,
    pub problem: String,
}

/// A parsed log.
#[derive(Clone, Debug)]
pub struct CsvLog {
    /// Samples in file order (not yet guarded: may hold NaN, backwards time, ...).
    pub samples: Vec<Sample>,
    /// The unit the timestamps were read in.
    pub unit: TimeUnit,
    /// Number of malformed lines skipped.
    pub malformed_count: usize,
    /// The first [`KEPT_LINE_ERRORS`] of them.
    pub malformed: Vec<LineError>,
}

/// A timestamp as written: integers keep all their digits (ticks need 19).
#[derive(Clone, Copy, Debug)]
enum RawTime {
    Int(i128),
    Float(f64),
}

impl RawTime {
    fn as_f64(self) -> f64 {
        match self {
            RawTime::Int(i) => i as f64,
            RawTime::Float(f) => f,
        }
    }
}

/// Reads a log file; `unit` `None` detects it.
pub fn read_csv(path: &Path, unit: Option<TimeUnit>) -> Result<CsvLog, CsvError> {
    let text = std::fs::read_to_string(path).map_err(|source| CsvError::Io {
        path: path.to_owned(),
        source,
    })?;
    parse_csv(&text, unit).ok_or_else(|| {
        let malformed = text
            .lines()
            .filter(|l| !l.trim().is_empty())
            .count()
            .saturating_sub(1);
        CsvError::Empty {
            path: path.to_owned(),
            malformed,
        }
    })
}

/// Parses log text; `None` when no line holds a sample.
pub fn parse_csv(text: &str, unit: Option<TimeUnit>) -> Option<CsvLog> {
    let mut rows: Vec<(RawTime, Pose)> = Vec::new();
    let mut malformed = Vec::new();
    let mut malformed_count = 0;
    let mut stated = None;
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if let Some(u) = line.strip_prefix("# unit:") {
            stated = u.trim().parse().ok();
        }
        let header = rows.is_empty()
            && malformed_count == 0
            && line.starts_with(|c: char| c.is_alphabetic());
        if line.is_empty() || line.starts_with('#') || header {
            continue;
        }
        match parse_line(line) {
            Ok(row) => rows.push(row),
            Err(problem) => {
                malformed_count += 1;
                if malformed.len() < KEPT_LINE_ERRORS {
                    malformed.push(LineError {
                        line: i + 1,
                        problem,
                    });
                }
            }
        }
    }
    if rows.is_empty() {
        return None;
    }
    let unit = unit
        .or(stated)
        .unwrap_or_else(|| detect_unit(&rows.iter().map(|r| r.0).collect::<Vec<_>>()));
    // Integers are rebased exactly (19-digit ticks do not fit an f64); mixed files in f64.
    let all_int = rows.iter().all(|r| matches!(r.0, RawTime::Int(_)));
    let origin_int = rows
        .iter()
        .filter_map(|r| {
            if let RawTime::Int(i) = r.0 {
                Some(i)
            } else {
                None
            }
        })
        .min();
    let origin = rows
        .iter()
        .map(|r| r.0.as_f64())
        .fold(f64::INFINITY, f64::min);
    let samples = rows
        .into_iter()
        .map(|(t, pose)| {
            let rel = match (t, origin_int) {
                (RawTime::Int(i), Some(o)) if all_int => (i - o) as f64,
                _ => t.as_f64() - origin,
            };
            Sample::new((rel * unit.ns()).round() as u64, pose)
        })
        .collect();
    Some(CsvLog {
        samples,
        unit,
        malformed_count,
        malformed,
    })
}

fn parse_line(line: &str) -> Result<(RawTime, Pose), String> {
    let fields: Vec<&str> = line.split(',').map(str::trim).collect();
    if fields.len() != 8 {
        return Err(format!(
            "expected 8 fields (timestamp,x,y,z,qx,qy,qz,qw), found {}",
            fields.len()
        ));
    }
    let t = if let Ok(i) = fields[0].parse::<i128>() {
        RawTime::Int(i)
    } else {
        match fields[0].parse::<f64>() {
            Ok(f) if f.is_finite() => RawTime::Float(f),
            _ => return Err(format!("timestamp `{}` is not a finite number", fields[0])),
        }
    };
    const NAMES: [&str; 8] = ["timestamp", "x", "y", "z", "qx", "qy", "qz", "qw"];
    let mut v = [0.0f32; 7];
    for (k, slot) in v.iter_mut().enumerate() {
        *slot = fields[k + 1]
            .parse::<f32>()
            .map_err(|_| format!("field {} `{}` is not a number", NAMES[k + 1], fields[k + 1]))?;
    }
    Ok((
        t,
        Pose::new(
            Vec3::new(v[0], v[1], v[2]),
            Quat::from_xyzw(v[3], v[4], v[5], v[6]),
        ),
    ))
}

fn detect_unit(times: &[RawTime]) -> TimeUnit {
    let first = times[0].as_f64().abs();
    if (5e17..7e17).contains(&first) {
        return TimeUnit::DotNetTicks;
    }
    if first >= 1e18 {
        return TimeUnit::Nanoseconds;
    }
    if first >= 1e15 {
        return TimeUnit::Microseconds;
    }
    if first >= 1e12 {
        return TimeUnit::Milliseconds;
    }
    if first >= 1e9 {
        return TimeUnit::Seconds;
    }
    let mut steps: Vec<f64> = times
        .windows(2)
        .map(|w| w[1].as_f64() - w[0].as_f64())
        .filter(|d| *d > 0.0)
        .collect();
    if steps.is_empty() {
        return TimeUnit::Nanoseconds;
    }
    let mid = steps.len() / 2;
    let median = *steps.select_nth_unstable_by(mid, f64::total_cmp).1;
    if median <= 1.0 {
        TimeUnit::Seconds
    } else if median <= 1e3 {
        TimeUnit::Milliseconds
    } else if median <= 1e6 {
        TimeUnit::Microseconds
    } else {
        TimeUnit::Nanoseconds
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trace(n: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../shared/tracking/pred6dof")
            .join(n)
    }

    #[test]
    fn hololens_trace_is_read_in_dotnet_ticks() {
        let log = read_csv(&trace("1.csv"), None).unwrap();
        assert_eq!(log.unit, TimeUnit::DotNetTicks);
        assert_eq!(log.malformed_count, 0);
        assert_eq!(log.samples.len(), 4664);
        assert_eq!(log.samples[0].t_ns, 0);
        // 637231069485903882 - 637231069485244909 ticks = 658973 ticks = 65.8973 ms.
        assert_eq!(log.samples[1].t_ns, 65_897_300);
        let span = log.samples.last().unwrap().t_ns as f64 * 1e-9;
        assert!(
            (60.0..120.0).contains(&span),
            "a little over a minute, got {span} s"
        );
        assert!((log.samples[0].pose.position.y - 0.0841746).abs() < 1e-7);
    }

    #[test]
    fn units_are_detected_from_magnitude_and_step() {
        let line = |t: &str| format!("{t},0,0,0,0,0,0,1\n");
        let cases = [
            (
                ["1700000000000000000", "1700000000016666666"],
                TimeUnit::Nanoseconds,
            ),
            (
                ["1700000000000000", "1700000000016666"],
                TimeUnit::Microseconds,
            ),
            (["1700000000000", "1700000000016"], TimeUnit::Milliseconds),
            (["1700000000.0", "1700000000.016"], TimeUnit::Seconds),
            (["0.0", "0.0166"], TimeUnit::Seconds),
            (["0", "16"], TimeUnit::Milliseconds),
            (["0", "16666"], TimeUnit::Microseconds),
            (["0", "16666666"], TimeUnit::Nanoseconds),
        ];
        for (times, unit) in cases {
            let text = format!(
                "timestamp,x,y,z,qx,qy,qz,qw\n{}{}",
                line(times[0]),
                line(times[1])
            );
            let log = parse_csv(&text, None).unwrap();
            assert_eq!(log.unit, unit, "{times:?}");
            assert!(
                (log.samples[1].t_ns as f64 - 16.6e6).abs() < 1e6,
                "{times:?}: {}",
                log.samples[1].t_ns
            );
        }
        let stated =
            parse_csv(&format!("# unit: us\n{}{}", line("0"), line("16666")), None).unwrap();
        assert_eq!(
            (stated.unit, stated.samples[1].t_ns),
            (TimeUnit::Microseconds, 16_666_000)
        );
        let forced = parse_csv(
            &format!("{}{}", line("0"), line("166666")),
            Some(TimeUnit::DotNetTicks),
        )
        .unwrap();
        assert_eq!(forced.samples[1].t_ns, 16_666_600);
    }

    #[test]
    fn malformed_lines_are_counted_with_line_numbers() {
        let text = "timestamp,x,y,z,qx,qy,qz,qw\n0,0,0,0,0,0,0,1\n1,2,3\n\n2,a,0,0,0,0,0,1\n3,0,0,0,0,0,0,NaN\n";
        let log = parse_csv(text, Some(TimeUnit::Milliseconds)).unwrap();
        assert_eq!(
            log.samples.len(),
            2,
            "NaN parses; the guard rejects it later"
        );
        assert_eq!(log.malformed_count, 2);
        assert_eq!(log.malformed[0].line, 3);
        assert!(log.malformed[0].problem.contains("expected 8 fields"));
        assert_eq!(log.malformed[1].line, 5);
        assert!(log.malformed[1].problem.contains("field x `a`"));
    }

    #[test]
    fn files_without_samples_are_errors_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("empty.csv");
        std::fs::write(&path, "timestamp,x,y,z,qx,qy,qz,qw\ngarbage\n").unwrap();
        let err = read_csv(&path, None).unwrap_err().to_string();
        assert!(
            err.contains("empty.csv") && err.contains("no valid sample"),
            "{err}"
        );
        let err = read_csv(&dir.path().join("missing.csv"), None)
            .unwrap_err()
            .to_string();
        assert!(err.contains("missing.csv"), "{err}");
    }
}
