//! A scripted input session: a user standing still in the room, holding the wand ahead of
//! them level, while the joystick follows a list of steps (so many seconds at such forward
//! and turn deflections). Written as a session log ([`crate::session_log`]) that `sim` and
//! `master` replay like a recorded one, e.g. a walk through a scene for tests and demos.

use std::io::Write;
use std::str::FromStr;

use glam::{Quat, Vec3};

use crate::input::{InputEvent, InputSample};
use crate::pose::{Pose, Sample};
use crate::session_log::SessionWriter;

/// One step of the script: `seconds` with the joystick at `forward` and `turn` (−1..1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Step {
    pub seconds: f64,
    pub forward: f64,
    pub turn: f64,
}

impl FromStr for Step {
    type Err = String;
    /// `SECONDS:FORWARD:TURN`, e.g. `3:1:0` (3 s straight ahead) or `2:0:-0.5`.
    fn from_str(s: &str) -> Result<Step, String> {
        let f: Vec<&str> = s.split(':').collect();
        if f.len() != 3 {
            return Err(format!("step `{s}` is not SECONDS:FORWARD:TURN"));
        }
        let num = |k: usize, what: &str| {
            f[k].trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("step `{s}`: {what} `{}` is not a number", f[k]))
        };
        let step = Step {
            seconds: num(0, "seconds")?,
            forward: num(1, "forward")?,
            turn: num(2, "turn")?,
        };
        if !(step.seconds > 0.0 && step.seconds <= 3600.0) {
            return Err(format!("step `{s}`: seconds must be in (0, 3600]"));
        }
        if step.forward.abs() > 1.0 || step.turn.abs() > 1.0 {
            return Err(format!("step `{s}`: deflections must be in [−1, 1]"));
        }
        Ok(step)
    }
}

/// Where the scripted user stands: the head 1.6 m over the room's centre looking at the
/// front wall (−Z), the wand 30 cm ahead of the waist, level, pointing the same way.
pub fn standing() -> (Pose, Pose) {
    (
        Pose::new(Vec3::new(0.0, 1.6, 0.0), Quat::IDENTITY),
        Pose::new(Vec3::new(0.15, 1.1, -0.3), Quat::IDENTITY),
    )
}

/// Writes the session: head and wand rows `pose_hz` times a second, and an `axes` row
/// (`turn, forward`: channels 0 and 1, the config's defaults) at the start of each step and
/// one of zeros at the end. Returns the rows written.
pub fn write_script(out: impl Write, steps: &[Step], pose_hz: f64) -> std::io::Result<usize> {
    let (head, wand) = standing();
    let mut w = SessionWriter::new(out)?;
    let total: f64 = steps.iter().map(|s| s.seconds).sum();
    let ns = |s: f64| (s * 1e9).round() as u64;
    let mut rows = 0;
    let mut t_step = 0.0;
    let mut axes = steps
        .iter()
        .map(|s| {
            let row = InputSample::new(ns(t_step), InputEvent::Axes(vec![s.turn, s.forward]));
            t_step += s.seconds;
            row
        })
        .chain(std::iter::once(InputSample::new(
            ns(total),
            InputEvent::Axes(vec![0.0, 0.0]),
        )))
        .peekable();
    let poses = (total * pose_hz).ceil() as u64;
    for k in 0..=poses {
        let t = ns(k as f64 / pose_hz);
        while let Some(a) = axes.next_if(|a| a.t_ns <= t) {
            w.input(&a)?;
            rows += 1;
        }
        w.head(&Sample::new(t, head))?;
        w.wand(&Sample::new(t, wand))?;
        rows += 2;
    }
    for a in axes {
        w.input(&a)?;
        rows += 1;
    }
    w.finish()?;
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::session_log::parse_session;
    use std::path::Path;

    #[test]
    fn a_script_reads_back_as_its_steps() {
        let steps: Vec<Step> = ["2:1:0", "1.5:0:-1"]
            .iter()
            .map(|s| s.parse().unwrap())
            .collect();
        let mut out = Vec::new();
        write_script(&mut out, &steps, 2.0).unwrap();
        let log = parse_session(std::str::from_utf8(&out).unwrap(), Path::new("s")).unwrap();
        let axes: Vec<(u64, InputEvent)> = log
            .inputs
            .iter()
            .map(|e| (e.t_ns, e.event.clone()))
            .collect();
        assert_eq!(
            axes,
            vec![
                (0, InputEvent::Axes(vec![0.0, 1.0])),
                (2_000_000_000, InputEvent::Axes(vec![-1.0, 0.0])),
                (3_500_000_000, InputEvent::Axes(vec![0.0, 0.0])),
            ]
        );
        assert_eq!(log.head.len(), 8);
        assert_eq!(log.head.last().unwrap().t_ns, 3_500_000_000);
        assert!("2:x:0".parse::<Step>().unwrap_err().contains("forward `x`"));
        assert!("2:1".parse::<Step>().is_err() && "0:1:0".parse::<Step>().is_err());
    }
}
