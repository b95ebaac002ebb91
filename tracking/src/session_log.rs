//! The session log: a head log (`timestamp,x,y,z,qx,qy,qz,qw`, as [`crate::csv_log`]
//! reads) extended with rows of the other input devices, each tagged by its device in its
//! first field:
//!
//! ```text
//! # unit: ns
//! # session: head, wand, buttons, axes
//! timestamp,x,y,z,qx,qy,qz,qw
//! 0,0.1,1.6,0.2,0,0,0,1                    the head (untagged, as in every head log)
//! wand,0,0.2,1.1,-0.3,0,0,0,1              the wand's pose
//! button,5000000,0,1                       button 0 went down (1) or up (0)
//! buttons,5000000,1,0                      every button's state at once
//! axes,8333333,0,0.5                       every joystick channel at once
//! time,9000000,2026-06-21T14:30            the scene's time of day from then on
//! ```
//!
//! A `time` row's time of day is the site's local standard time, to the minute, as
//! `--when` takes it; the master steps the sun and sky to it at that point of the replay.
//!
//! A head log without tagged rows is still read by [`crate::csv_log`], leniently; a
//! session log (a `# session` line or any tagged row) is read strictly: a row that is not
//! one of the above, a number that is not finite, or a device's time going backwards is
//! an error naming the file and the line. Times are integers in the `# unit:` line's unit
//! (ns when absent), rebased so that the first head row is at 0 (the first row when there
//! is no head row); a device's row before it is at 0. The head's replay starts at its
//! first sample, so every device keeps its time relative to the head.

use std::fmt::Write as _;
use std::io::Write;
use std::path::{Path, PathBuf};

use glam::{Quat, Vec3};

use crate::csv_log::TimeUnit;
use chrono::NaiveDateTime;

use crate::input::{InputEvent, InputSample, TIME_FORMAT};
use crate::pose::{Pose, Sample};
use crate::vrpn_input::{MAX_BUTTONS, MAX_CHANNELS};

/// The comment line that marks a session log.
pub const SESSION_LINE: &str = "# session: head, wand, buttons, axes";
/// The farthest apart (s) the first rows of two devices of one session may be.
pub const MAX_CLOCK_SPREAD_S: f64 = 86_400.0;
/// The head rows' header.
pub const HEADER: &str = "timestamp,x,y,z,qx,qy,qz,qw";

/// A session log could not be read.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    #[error("cannot read session log {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("session log {path}, line {line}: {problem} (row `{row}`)")]
    Row {
        path: PathBuf,
        line: usize,
        row: String,
        problem: String,
    },
    #[error("session log {path} has no rows")]
    Empty { path: PathBuf },
}

/// A session's devices, times in ns from the first head row.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SessionLog {
    pub head: Vec<Sample>,
    pub wand: Vec<Sample>,
    /// Button and axis events in file order.
    pub inputs: Vec<InputSample>,
}

/// True when `text` is a session log rather than a plain head log.
pub fn is_session(text: &str) -> bool {
    text.lines().any(|l| {
        let l = l.trim_start();
        l.starts_with("# session")
            || ["wand,", "button,", "buttons,", "axes,", "time,"]
                .iter()
                .any(|t| l.starts_with(t))
    })
}

/// Reads a session log.
pub fn read_session(path: &Path) -> Result<SessionLog, SessionError> {
    let text = std::fs::read_to_string(path).map_err(|source| SessionError::Io {
        path: path.to_owned(),
        source,
    })?;
    parse_session(&text, path)
}

/// Which device a row belongs to.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Device {
    Head,
    Wand,
    Buttons,
    Axes,
}

enum Row {
    Pose(Device, i128, Pose),
    Input(i128, InputEvent),
}

/// Parses session log text; `path` names it in errors.
pub fn parse_session(text: &str, path: &Path) -> Result<SessionLog, SessionError> {
    let mut unit = TimeUnit::Nanoseconds;
    let mut rows = Vec::new();
    let mut last: [Option<i128>; 4] = [None; 4];
    // Each device's first time and line.
    let mut first: [Option<(i128, usize)>; 4] = [None; 4];
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        let bad = |problem: String| SessionError::Row {
            path: path.to_owned(),
            line: i + 1,
            row: line.chars().take(80).collect(),
            problem,
        };
        if let Some(u) = line.strip_prefix("# unit:") {
            unit = u.trim().parse().map_err(bad)?;
            continue;
        }
        if line.is_empty() || line.starts_with('#') || line == HEADER {
            continue;
        }
        let row = parse_row(line).map_err(bad)?;
        let (device, t) = match &row {
            Row::Pose(d, t, _) => (*d, *t),
            Row::Input(t, InputEvent::Axes(_)) => (Device::Axes, *t),
            Row::Input(t, _) => (Device::Buttons, *t),
        };
        let prev = &mut last[device as usize];
        if let Some(p) = *prev
            && t < p
        {
            return Err(bad(format!(
                "time {t} is before the {device:?} row before it ({p})"
            )));
        }
        *prev = Some(t);
        first[device as usize].get_or_insert((t, i + 1));
        rows.push(row);
    }
    let origin = rows
        .iter()
        .find_map(|r| match r {
            Row::Pose(Device::Head, t, _) => Some(*t),
            _ => None,
        })
        .or_else(|| {
            rows.iter()
                .map(|r| match r {
                    Row::Pose(_, t, _) | Row::Input(t, _) => *t,
                })
                .min()
        })
        .ok_or_else(|| SessionError::Empty {
            path: path.to_owned(),
        })?;
    // Devices on different clocks (a synthetic head from 0 and a VRPN server's Unix time)
    // would never meet in a replay: more than a day apart is refused.
    if let Some((t0, l0)) = first[Device::Head as usize] {
        for d in [Device::Wand, Device::Buttons, Device::Axes] {
            if let Some((t, line)) = first[d as usize]
                && ((t - t0) as f64 * unit.ns()).abs() > MAX_CLOCK_SPREAD_S * 1e9
            {
                return Err(SessionError::Row {
                    path: path.to_owned(),
                    line,
                    row: format!("{d:?} at {t}"),
                    problem: format!(
                        "the {d:?} rows start {:.0} s away from the head's (line {l0}): the devices are not on one clock",
                        (t - t0) as f64 * unit.ns() * 1e-9
                    ),
                });
            }
        }
    }
    let ns = |t: i128| ((t - origin).max(0) as f64 * unit.ns()).round() as u64;
    let mut log = SessionLog::default();
    for row in rows {
        match row {
            Row::Pose(Device::Wand, t, p) => log.wand.push(Sample::new(ns(t), p)),
            Row::Pose(_, t, p) => log.head.push(Sample::new(ns(t), p)),
            Row::Input(t, e) => log.inputs.push(InputSample::new(ns(t), e)),
        }
    }
    Ok(log)
}

fn int(field: &str, what: &str) -> Result<i128, String> {
    field
        .parse::<i128>()
        .map_err(|_| format!("{what} `{field}` is not an integer"))
}

fn number(field: &str, what: &str) -> Result<f64, String> {
    match field.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(format!("{what} `{field}` is not a finite number")),
    }
}

fn pose(fields: &[&str]) -> Result<Pose, String> {
    const NAMES: [&str; 7] = ["x", "y", "z", "qx", "qy", "qz", "qw"];
    if fields.len() != 7 {
        return Err(format!(
            "expected a time and 7 pose fields (x,y,z,qx,qy,qz,qw), found {} fields after the time",
            fields.len()
        ));
    }
    let mut v = [0.0f32; 7];
    for (k, slot) in v.iter_mut().enumerate() {
        *slot = number(fields[k], NAMES[k])? as f32;
    }
    let q = Quat::from_xyzw(v[3], v[4], v[5], v[6]);
    if (q.length() - 1.0).abs() > 1e-3 {
        return Err(format!("quaternion has length {}, not 1", q.length()));
    }
    Ok(Pose::new(Vec3::new(v[0], v[1], v[2]), q))
}

fn parse_row(line: &str) -> Result<Row, String> {
    let fields: Vec<&str> = line.split(',').map(str::trim).collect();
    let tagged = |n: usize| -> Result<i128, String> {
        if fields.len() < n {
            return Err(format!("a `{}` row needs at least {n} fields", fields[0]));
        }
        int(fields[1], "time")
    };
    match fields[0] {
        "wand" => Ok(Row::Pose(Device::Wand, tagged(2)?, pose(&fields[2..])?)),
        "button" => {
            let t = tagged(4)?;
            if fields.len() != 4 {
                return Err("a `button` row is button,TIME,INDEX,STATE".into());
            }
            let index = int(fields[2], "button")?;
            if !(0..MAX_BUTTONS as i128).contains(&index) {
                return Err(format!("button {index} is outside 0..{MAX_BUTTONS}"));
            }
            let pressed = match fields[3] {
                "0" => false,
                "1" => true,
                s => return Err(format!("button state `{s}` is not 0 or 1")),
            };
            Ok(Row::Input(
                t,
                InputEvent::Button {
                    index: index as u32,
                    pressed,
                },
            ))
        }
        "buttons" => {
            let t = tagged(2)?;
            if fields.len() - 2 > MAX_BUTTONS {
                return Err(format!("more than {MAX_BUTTONS} buttons"));
            }
            let states = fields[2..]
                .iter()
                .map(|s| match *s {
                    "0" => Ok(false),
                    "1" => Ok(true),
                    s => Err(format!("button state `{s}` is not 0 or 1")),
                })
                .collect::<Result<_, _>>()?;
            Ok(Row::Input(t, InputEvent::Buttons(states)))
        }
        "time" => {
            let t = tagged(3)?;
            if fields.len() != 3 {
                return Err("a `time` row is time,TIME,YYYY-MM-DDTHH:MM".into());
            }
            let when = NaiveDateTime::parse_from_str(fields[2], TIME_FORMAT).map_err(|_| {
                format!(
                    "time of day `{}` is not YYYY-MM-DDTHH:MM (local standard time)",
                    fields[2]
                )
            })?;
            Ok(Row::Input(t, InputEvent::Time(when)))
        }
        "axes" => {
            let t = tagged(2)?;
            if fields.len() - 2 > MAX_CHANNELS {
                return Err(format!("more than {MAX_CHANNELS} axis channels"));
            }
            let values = fields[2..]
                .iter()
                .enumerate()
                .map(|(k, s)| number(s, &format!("axis {k}")))
                .collect::<Result<_, _>>()?;
            Ok(Row::Input(t, InputEvent::Axes(values)))
        }
        first if first.starts_with(|c: char| c.is_ascii_digit() || c == '-') => {
            let t = int(first, "timestamp")?;
            Ok(Row::Pose(Device::Head, t, pose(&fields[1..])?))
        }
        other => Err(format!(
            "`{other}` is not a timestamp or a device (wand, button, buttons, axes, time)"
        )),
    }
}

/// Writes a session log, row by row, times in ns.
pub struct SessionWriter<W: Write> {
    out: W,
}

impl<W: Write> SessionWriter<W> {
    /// Starts a log: the unit, the session line, the head header.
    pub fn new(mut out: W) -> std::io::Result<Self> {
        writeln!(out, "# unit: ns\n{SESSION_LINE}\n{HEADER}")?;
        Ok(SessionWriter { out })
    }

    fn pose_fields(s: &Sample) -> String {
        let (p, q) = (s.pose.position, s.pose.orientation);
        format!(
            "{},{},{},{},{},{},{},{}",
            s.t_ns, p.x, p.y, p.z, q.x, q.y, q.z, q.w
        )
    }

    pub fn head(&mut self, s: &Sample) -> std::io::Result<()> {
        writeln!(self.out, "{}", Self::pose_fields(s))
    }

    pub fn wand(&mut self, s: &Sample) -> std::io::Result<()> {
        writeln!(self.out, "wand,{}", Self::pose_fields(s))
    }

    pub fn input(&mut self, s: &InputSample) -> std::io::Result<()> {
        let mut row = String::new();
        let bit = |b: bool| if b { "1" } else { "0" };
        match &s.event {
            InputEvent::Button { index, pressed } => {
                let _ = write!(row, "button,{},{index},{}", s.t_ns, bit(*pressed));
            }
            InputEvent::Buttons(states) => {
                let _ = write!(row, "buttons,{}", s.t_ns);
                for b in states {
                    let _ = write!(row, ",{}", bit(*b));
                }
            }
            InputEvent::Axes(values) => {
                let _ = write!(row, "axes,{}", s.t_ns);
                for v in values {
                    let _ = write!(row, ",{v}");
                }
            }
            InputEvent::Time(when) => {
                let _ = write!(row, "time,{},{}", s.t_ns, when.format(TIME_FORMAT));
            }
        }
        writeln!(self.out, "{row}")
    }

    /// The writer, flushed.
    pub fn finish(mut self) -> std::io::Result<W> {
        self.out.flush()?;
        Ok(self.out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(t: u64, x: f32) -> Sample {
        Sample::new(t, Pose::new(Vec3::new(x, 1.6, 0.0), Quat::IDENTITY))
    }

    #[test]
    fn written_sessions_read_back_exactly_with_times_from_the_first_head_row() {
        let mut w = SessionWriter::new(Vec::new()).unwrap();
        // The wand's first row comes before the head's: it is clamped to 0.
        w.wand(&sample(1_000, 0.5)).unwrap();
        w.head(&sample(5_000, 0.25)).unwrap();
        let press = InputSample::new(
            6_000,
            InputEvent::Button {
                index: 2,
                pressed: true,
            },
        );
        let axes = InputSample::new(7_000, InputEvent::Axes(vec![0.125, -1.0]));
        let states = InputSample::new(8_000, InputEvent::Buttons(vec![true, false]));
        let noon = NaiveDateTime::parse_from_str("2026-06-21T12:15", TIME_FORMAT).unwrap();
        let time = InputSample::new(8_500, InputEvent::Time(noon));
        w.input(&press).unwrap();
        w.input(&axes).unwrap();
        w.input(&states).unwrap();
        w.input(&time).unwrap();
        w.head(&sample(9_000, 0.75)).unwrap();
        let text = String::from_utf8(w.finish().unwrap()).unwrap();
        assert!(is_session(&text));
        let log = parse_session(&text, Path::new("s.csv")).unwrap();
        assert_eq!(log.head, vec![sample(0, 0.25), sample(4_000, 0.75)]);
        assert_eq!(log.wand, vec![sample(0, 0.5)]);
        let shifted = |s: &InputSample| InputSample::new(s.t_ns - 5_000, s.event.clone());
        assert_eq!(
            log.inputs,
            vec![
                shifted(&press),
                shifted(&axes),
                shifted(&states),
                shifted(&time)
            ]
        );
        // The head rows alone are a head log the lenient reader still reads.
        let head = crate::csv_log::parse_csv(&text, None).unwrap();
        assert_eq!(head.samples.len(), 2);
    }

    #[test]
    fn old_head_logs_are_not_sessions() {
        let old = "# unit: ns\ntimestamp,x,y,z,qx,qy,qz,qw\n0,0,1.6,0,0,0,0,1\n";
        assert!(!is_session(old));
        // Read strictly all the same, they give their head.
        let log = parse_session(old, Path::new("old.csv")).unwrap();
        assert_eq!(log.head.len(), 1);
        assert!(log.wand.is_empty() && log.inputs.is_empty());
    }

    #[test]
    fn garbage_rows_are_refused_naming_the_line() {
        let good = "# unit: ns\n# session: head, wand, buttons, axes\ntimestamp,x,y,z,qx,qy,qz,qw\n0,0,1.6,0,0,0,0,1\naxes,0,0,1\n";
        assert!(parse_session(good, Path::new("walk.csv")).is_ok());
        let cases = [
            ("axes,10,0,zz\n", "axis 1 `zz`"),
            ("button,10,0,2\n", "button state `2`"),
            ("button,10,999,1\n", "button 999"),
            ("wand,10,0,1,0,0,0,0\n", "7 pose fields"),
            ("wand,10,0,1,0,0,0,0,5\n", "quaternion has length 5"),
            (
                "joystick,10,0\n",
                "`joystick` is not a timestamp or a device",
            ),
            ("10,0,NaN,0,0,0,0,1\n", "y `NaN`"),
            ("axes,-5,0,0\n", "before the Axes row before it"),
            (
                "time,10,2026-06-21 14:30\n",
                "`2026-06-21 14:30` is not YYYY-MM-DDTHH:MM",
            ),
            ("time,10,2026-13-21T14:30\n", "is not YYYY-MM-DDTHH:MM"),
            ("time,10\n", "at least 3 fields"),
            (
                "wand,1796301471584801000,0,1,0,0,0,0,1\n",
                "not on one clock",
            ),
        ];
        for (row, what) in cases {
            let text = format!("{good}{row}");
            let e = parse_session(&text, Path::new("walk.csv"))
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("walk.csv, line 6") && e.contains(what),
                "{row:?}: {e}"
            );
        }
    }
}
