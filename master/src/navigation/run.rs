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

use super::Navigator;
use super::input::Inputs;
use super::placement::Placement;
use crate::head::Clock;

/// Where the input devices come from (source strings: `vrpn://…`, `file:…`); each falls
/// back on the config's `[navigation]` key.
#[derive(Clone, Debug, Default)]
pub struct Devices {
    pub wand: Option<String>,
    pub buttons: Option<String>,
    pub axes: Option<String>,
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
        };
        if d.is_empty()
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

    pub fn is_empty(&self) -> bool {
        self.wand.is_none() && self.buttons.is_none() && self.axes.is_none()
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
        Ok(Some(NavigationRun::new(navigator, inputs, scene)))
    }

    pub fn new(navigator: Navigator, inputs: Inputs, scene: Option<Arc<Scene>>) -> Self {
        NavigationRun {
            navigator,
            inputs,
            scene,
            last_ns: None,
            held: Vec::new(),
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
        self.navigator.step(head, &input, dt, self.scene.as_deref())
    }

    /// The transform the frame state sends.
    pub fn matrix(p: &Placement) -> DMat4 {
        p.to_mat4()
    }
}
