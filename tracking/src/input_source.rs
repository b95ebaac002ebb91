//! Where a wand, buttons and joystick axes come from: a live VRPN device
//! (`vrpn://Wand0@host#1`, `vrpn://Buttons0@host`, `vrpn://Joystick0@host`) or a recorded
//! session log (`file:session.csv`, its `wand`, `button`/`buttons` or `axes` rows). The
//! wand is a tracker sensor like the head ([`crate::source::TrackerSource`]); buttons and
//! axes are event streams ([`InputSource`]), each event stamped on arrival.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::input::{InputEvent, InputSample};
use crate::session_log::{SessionError, is_session, read_session};
use crate::source::{Pacing, Replay, SourceError, SourceSpec, TrackerSource, open};
use crate::vrpn::{ClientOptions, Follow, VrpnClient, VrpnEvent};
use crate::vrpn_input::InputKind;

/// An input device could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    #[error("{what} `{spec}`: {problem}")]
    Spec {
        what: &'static str,
        spec: String,
        problem: String,
    },
    #[error(transparent)]
    Session(#[from] SessionError),
    #[error(transparent)]
    Source(#[from] SourceError),
}

/// What an input source has next.
#[derive(Clone, Debug, PartialEq)]
pub enum NextInput {
    /// An event and when it arrived on this machine.
    Event(InputSample, Instant),
    /// Nothing arrived before the deadline.
    Idle,
    /// A recorded source has no more events.
    End,
}

/// A stream of button or axis events.
pub enum InputSource {
    /// A live VRPN device.
    Vrpn(VrpnClient),
    /// A recorded session's events of one kind, in order.
    Replay(VecDeque<InputSample>),
}

impl InputSource {
    /// The next event, waiting until `deadline` at most (a recording answers at once).
    pub fn next(&mut self, deadline: Instant) -> NextInput {
        match self {
            InputSource::Replay(events) => match events.pop_front() {
                Some(e) => NextInput::Event(e, Instant::now()),
                None => NextInput::End,
            },
            InputSource::Vrpn(client) => loop {
                let wait = deadline.saturating_duration_since(Instant::now());
                match client.recv_timeout(wait) {
                    Ok(VrpnEvent::Input(e, at)) => return NextInput::Event(e, at),
                    Ok(VrpnEvent::Connected { addr }) => {
                        tracing::info!("connected to VRPN server {addr}")
                    }
                    Ok(VrpnEvent::Disconnected(e)) => tracing::warn!("{e}"),
                    Ok(VrpnEvent::Sample(..)) => {}
                    Err(_) => return NextInput::Idle,
                }
            },
        }
    }

    /// True for live devices.
    pub fn endless(&self) -> bool {
        matches!(self, InputSource::Vrpn(_))
    }
}

fn spec_error(what: &'static str, spec: &str, problem: impl Into<String>) -> InputError {
    InputError::Spec {
        what,
        spec: spec.to_owned(),
        problem: problem.into(),
    }
}

/// A recorded file named by `file:PATH`.
fn file_path(spec: &str) -> Option<PathBuf> {
    spec.strip_prefix("file:").map(PathBuf::from)
}

/// Opens buttons (`kind` = [`InputKind::Buttons`]) or axes from `spec`: `vrpn://DEVICE@HOST[:PORT]`
/// or `file:PATH` of a session log.
pub fn open_input(spec: &str, kind: InputKind) -> Result<InputSource, InputError> {
    let what = match kind {
        InputKind::Buttons => "buttons",
        InputKind::Analog => "axes",
    };
    if let Some(rest) = spec.strip_prefix("vrpn://") {
        let target = rest.parse().map_err(|e| spec_error(what, spec, e))?;
        return Ok(InputSource::Vrpn(VrpnClient::spawn_following(
            target,
            Follow::Input(kind),
            ClientOptions::default(),
        )));
    }
    let Some(path) = file_path(spec) else {
        return Err(spec_error(
            what,
            spec,
            "expected vrpn://DEVICE@HOST[:PORT] or file:PATH (a session log)",
        ));
    };
    Ok(InputSource::Replay(session_inputs(&path, kind)?.into()))
}

/// A session log's events of one kind.
pub fn session_inputs(path: &Path, kind: InputKind) -> Result<Vec<InputSample>, InputError> {
    let log = read_session(path)?;
    Ok(log
        .inputs
        .into_iter()
        .filter(|e| matches!(e.event, InputEvent::Axes(_)) == (kind == InputKind::Analog))
        .collect())
}

/// Opens a wand: a tracker sensor (`vrpn://Wand0@host#1`, `synthetic:NAME`), the `wand`
/// rows of a session log, or a plain pose log (`file:PATH` without `wand` rows: its pose
/// rows are the wand's).
pub fn open_wand(spec: &str, pacing: Pacing) -> Result<Box<dyn TrackerSource>, InputError> {
    if let Some(path) = file_path(spec) {
        let text = std::fs::read_to_string(&path).map_err(|source| SessionError::Io {
            path: path.clone(),
            source,
        })?;
        if is_session(&text) {
            let log = crate::session_log::parse_session(&text, &path)?;
            let rows = if log.wand.is_empty() {
                log.head
            } else {
                log.wand
            };
            return Ok(Box::new(Replay::new(rows, pacing)));
        }
    }
    let parsed: SourceSpec = spec
        .parse()
        .map_err(|e: String| spec_error("wand", spec, e))?;
    Ok(open(&parsed, pacing, None)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::source::Next;

    #[test]
    fn a_session_log_gives_the_wand_buttons_and_axes_apart() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.csv");
        std::fs::write(
            &path,
            "# unit: ns\n# session: head, wand, buttons, axes\n0,0,1.6,0,0,0,0,1\nwand,0,0.5,1,0,0,0,0,1\nbutton,10,0,1\naxes,20,0,1\n",
        )
        .unwrap();
        let spec = format!("file:{}", path.display());
        let mut wand = open_wand(&spec, Pacing::AsFastAsPossible).unwrap();
        let far = Instant::now() + std::time::Duration::from_secs(60);
        assert!(matches!(wand.next(far), Next::Sample(s, _) if s.pose.position.x == 0.5));
        assert_eq!(wand.next(far), Next::End);
        let mut buttons = open_input(&spec, InputKind::Buttons).unwrap();
        assert!(matches!(
            buttons.next(far),
            NextInput::Event(
                InputSample {
                    t_ns: 10,
                    event: InputEvent::Button {
                        index: 0,
                        pressed: true
                    }
                },
                _
            )
        ));
        assert_eq!(buttons.next(far), NextInput::End);
        let mut axes = open_input(&spec, InputKind::Analog).unwrap();
        assert!(matches!(
            axes.next(far),
            NextInput::Event(InputSample { t_ns: 20, .. }, _)
        ));
        let e = open_input("http://x", InputKind::Analog)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("axes `http://x`"), "{e}");
    }
}
