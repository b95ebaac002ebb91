//! Navigation in the master's frame loop: the devices read up to the frame's time, the
//! navigator stepped by the frame clock's time step (so a replay does not depend on how
//! fast the machine is), the scene it collides with.

use std::sync::Arc;

use glam::DMat4;
use holocave_cave::Cave;
use holocave_scene::Scene;
use holocave_tracking::Pose;
use holocave_tracking::input::InputEvent;
use holocave_tracking::input_source::{InputError, open_input, open_wand};
use holocave_tracking::session_log::{is_session, read_session};
use holocave_tracking::source::Pacing;
use holocave_tracking::vrpn_input::InputKind;

use std::fs::File;
use std::io::{BufWriter, Write};

use holocave_protocol::cluster::DeskInput;
use holocave_tracking::Sample;
use holocave_tracking::input::InputSample;
use holocave_tracking::session_log::SessionWriter;

use super::Navigator;
use super::desk::{Desk, combine};
use super::input::{InputState, Inputs, WandPose};
use super::placement::Placement;
use crate::head::Clock;

/// Where the input devices come from (source strings: `vrpn://…`, `file:…`); each falls
/// back on the config's `[navigation]` key.
#[derive(Clone, Debug, Default)]
pub struct Devices {
    pub wand: Option<String>,
    pub buttons: Option<String>,
    pub axes: Option<String>,
    /// Take the keyboard and mouse of the nodes' windows (`--desk`).
    pub desk: bool,
}

impl Devices {
    /// These devices, each one not given taken from the config, and then, when none is
    /// bound at all and the head's `tracker` is a session log, the devices that log holds.
    pub fn resolve(&self, cave: &Cave, tracker: Option<&str>) -> Result<Devices, InputError> {
        let n = &cave.navigation;
        let mut d = Devices {
            wand: self.wand.clone().or_else(|| n.wand.clone()),
            buttons: self.buttons.clone().or_else(|| n.buttons.clone()),
            axes: self.axes.clone().or_else(|| n.axes.clone()),
            desk: self.desk,
        };
        if d.no_device()
            && let Some(spec) = tracker
            && let Some(path) = spec.strip_prefix("file:")
            && std::fs::read_to_string(path).is_ok_and(|t| is_session(&t))
        {
            let log = read_session(std::path::Path::new(path))?;
            let has = |axes: bool| {
                log.inputs
                    .iter()
                    .any(|e| matches!(e.event, InputEvent::Axes(_)) == axes)
            };
            d.wand = (!log.wand.is_empty()).then(|| spec.to_owned());
            d.buttons = has(false).then(|| spec.to_owned());
            d.axes = has(true).then(|| spec.to_owned());
        }
        Ok(d)
    }

    /// No device bound; the desk alone does not count (a session log's devices are
    /// still used with it).
    fn no_device(&self) -> bool {
        self.wand.is_none() && self.buttons.is_none() && self.axes.is_none()
    }

    pub fn is_empty(&self) -> bool {
        self.no_device() && !self.desk
    }
}

/// The navigation the master runs each frame.
pub struct NavigationRun {
    pub navigator: Navigator,
    pub inputs: Inputs,
    /// What walking, flying and teleporting collide with (`None`: no collisions, no floor).
    pub scene: Option<Arc<Scene>>,
    last_ns: Option<u64>,
    /// The buttons held at the last frame (changes are logged).
    held: Vec<bool>,
    /// The last frame's input (the wand and buttons moving objects read).
    last: InputState,
    /// The nodes' keyboards and mice (`--desk`), `None` when not taken.
    pub desk: Option<Desk>,
    /// Where the desk's changes are written as session-log rows (`desk.csv`).
    desk_log: Option<SessionWriter<BufWriter<File>>>,
}

impl NavigationRun {
    /// Opens `devices` (already resolved) on `clock`; `None` when no device is bound (the
    /// room then stays at the config's start transform).
    pub fn open(
        cave: &Cave,
        devices: &Devices,
        clock: Clock,
        scene: Option<Arc<Scene>>,
    ) -> Result<Option<NavigationRun>, InputError> {
        if devices.is_empty() {
            return Ok(None);
        }
        let pacing = match clock {
            Clock::Live => Pacing::RealTime,
            Clock::Replay => Pacing::AsFastAsPossible,
        };
        let wand = devices
            .wand
            .as_deref()
            .map(|w| open_wand(w, pacing))
            .transpose()?;
        let buttons = devices
            .buttons
            .as_deref()
            .map(|b| open_input(b, InputKind::Buttons))
            .transpose()?;
        let axes = devices
            .axes
            .as_deref()
            .map(|a| open_input(a, InputKind::Analog))
            .transpose()?;
        let inputs = Inputs::new(clock, wand, buttons, axes, cave.tracker_to_room);
        let navigator = Navigator::new(cave.navigation.clone(), &cave.room_to_scene);
        let mut run = NavigationRun::new(navigator, inputs, scene);
        if devices.desk {
            run.desk = Some(Desk::default());
        }
        Ok(Some(run))
    }

    pub fn new(navigator: Navigator, inputs: Inputs, scene: Option<Arc<Scene>>) -> Self {
        NavigationRun {
            navigator,
            inputs,
            scene,
            last_ns: None,
            held: Vec::new(),
            last: InputState::default(),
            desk: None,
            desk_log: None,
        }
    }

    /// Writes the desk's input to `path` as a session log's `button` and `axes` rows,
    /// stamped with the time of the frame that used them (after one head row at 0), so
    /// `--buttons file:PATH --axes file:PATH` on a replay clock replays the desk walk.
    pub fn log_desk(&mut self, path: &std::path::Path) -> std::io::Result<()> {
        let mut w = SessionWriter::new(BufWriter::new(File::create(path)?))?;
        w.head(&Sample::new(0, Pose::IDENTITY))?;
        self.desk_log = Some(w);
        Ok(())
    }

    /// A node's desk input (`None`: the node is gone). Ignored when the desk is not
    /// taken; an invalid one is dropped with a warning naming the node and the field.
    pub fn desk_message(&mut self, node: u64, input: Option<DeskInput>) {
        let Some(desk) = &mut self.desk else {
            if input.is_some() {
                tracing::debug!("node {node}: desk input ignored (the master runs without --desk)");
            }
            return;
        };
        let s = self.navigator.settings();
        match input {
            Some(i) => {
                if let Err(e) = desk.receive(s, node, i) {
                    tracing::warn!("node {node}: {e}; dropped");
                }
            }
            None => desk.forget(s, node),
        }
    }

    /// Flushes `desk.csv`.
    pub fn finish(&mut self) -> std::io::Result<()> {
        match self.desk_log.take() {
            Some(w) => w.finish()?.flush(),
            None => Ok(()),
        }
    }

    /// The transform of the frame at `now_ns` on the master's clock, for the head at `head`
    /// (room); the wand is moved by `recentring` as the head was. The first frame's step is
    /// zero long.
    pub fn frame(&mut self, now_ns: u64, head: &Pose, recentring: glam::Vec3) -> Placement {
        let dt = self
            .last_ns
            .map_or(0.0, |t| now_ns.saturating_sub(t) as f64 * 1e-9);
        self.last_ns = Some(now_ns);
        let before = self.held.clone();
        let mut input = self.inputs.advance(now_ns).clone();
        if let Some(desk) = &mut self.desk {
            let (state, events) = desk.take();
            input = combine(&input, &state);
            if let Some(w) = &mut self.desk_log {
                for e in events {
                    if let Err(e) = w.input(&InputSample::new(now_ns, e)) {
                        tracing::warn!("desk.csv: {e}; no longer written");
                        self.desk_log = None;
                        break;
                    }
                }
            }
        }
        if let Some(w) = &mut input.wand {
            w.position += recentring.as_dvec3();
        }
        for (b, &down) in input.buttons.iter().enumerate() {
            if before.get(b).copied().unwrap_or(false) != down {
                tracing::info!(
                    "navigation at {:.3} s: button {b} {}",
                    now_ns as f64 * 1e-9,
                    if down { "held" } else { "released" }
                );
            }
        }
        self.held.clone_from(&input.buttons);
        let place = self.navigator.step(head, &input, dt, self.scene.as_deref());
        self.last = input;
        place
    }

    /// The last frame's time inputs: a time of day set (a replayed `time` row) and the
    /// steps in minutes, the desk's keys' and the earlier and later buttons'
    /// ([`crate::sun_clock::SunClock::advance`] takes them).
    pub fn time_input(&self) -> (Option<chrono::NaiveDateTime>, i64) {
        let s = self.navigator.settings();
        let presses = |b: Option<usize>| {
            b.and_then(|b| self.last.presses.get(b))
                .map_or(0, |&p| i64::from(p))
        };
        let buttons = (presses(s.later_button) - presses(s.earlier_button)) * s.time_step_min;
        (self.last.time_set, self.last.time_step_min + buttons)
    }

    /// Notes in `desk.csv` (when written) that the time of day became `when` at `now_ns`,
    /// so the desk's replay sets it there.
    pub fn log_time(&mut self, now_ns: u64, when: chrono::NaiveDateTime) {
        if let Some(w) = &mut self.desk_log
            && let Err(e) = w.input(&InputSample::new(now_ns, InputEvent::Time(when)))
        {
            tracing::warn!("desk.csv: {e}; no longer written");
            self.desk_log = None;
        }
    }

    /// The last frame's wand in scene coordinates (room placed by `place`), and whether
    /// its object button is held: what carries a moving object.
    pub fn object_hand(&self, place: &Placement) -> (Option<WandPose>, bool) {
        let wand = self.last.wand.map(|w| WandPose {
            position: place.point(w.position),
            orientation: place.rotation * w.orientation,
        });
        (
            wand,
            self.last.held(self.navigator.settings().object_button),
        )
    }

    /// The transform the frame state sends.
    pub fn matrix(p: &Placement) -> DMat4 {
        p.to_mat4()
    }
}
