//! A desk user's keyboard and mouse (`node --window`, `sim --window`): each node's
//! [`DeskInput`] mapped onto the navigation's own inputs — the forward and turn axes on the
//! config's `forward_axis` and `turn_axis` channels (signed so they read as the joystick's
//! +1 forward and right), grab, teleport and the walk/fly key on `grab_button`,
//! `teleport_button` and `mode_button` — so every mode moves exactly as it does from a
//! wand, and `desk.csv` replays all of it. The master stays the only one that
//! integrates navigation.
//!
//! A node's time keys step the scene's time of day: each step is added once
//! ([`DeskInput::time_step_min`]), whatever else the node holds.
//!
//! The rule with several nodes and the VRPN devices: an axis is the first non-neutral one
//! of the nodes (by node id), else the devices'; a button is held when any node or device
//! holds it, and presses add up. A node that leaves releases everything it held.

use std::collections::BTreeMap;

use holocave_cave::Navigation;
use holocave_protocol::cluster::DeskInput;
use holocave_tracking::input::InputEvent;

use super::input::InputState;

/// The desk inputs of every node, and their merged state as navigation inputs.
#[derive(Clone, Debug, Default)]
pub struct Desk {
    nodes: BTreeMap<u64, DeskInput>,
    /// The merged desk input in channel form (buttons, presses since the last frame, axes).
    state: InputState,
    /// Changes since the last frame, as session-log events (for `desk.csv`).
    events: Vec<InputEvent>,
}

impl Desk {
    /// Node `node` sent `input`; an invalid one is refused with the error naming it.
    pub fn receive(&mut self, s: &Navigation, node: u64, input: DeskInput) -> Result<(), String> {
        input.validate()?;
        self.state.time_step_min += i64::from(input.time_step_min);
        self.nodes.insert(node, input);
        self.merge(s);
        Ok(())
    }

    /// Node `node` is gone: what it held is released.
    pub fn forget(&mut self, s: &Navigation, node: u64) {
        if self.nodes.remove(&node).is_some() {
            self.merge(s);
        }
    }

    /// The desk input of all nodes together.
    pub fn merged(&self) -> DeskInput {
        let mut m = DeskInput::NEUTRAL;
        for d in self.nodes.values() {
            if m.forward == 0.0 {
                m.forward = d.forward;
            }
            if m.turn == 0.0 {
                m.turn = d.turn;
            }
            m.grab |= d.grab;
            m.teleport |= d.teleport;
            m.mode |= d.mode;
        }
        m
    }

    fn merge(&mut self, s: &Navigation) {
        let m = self.merged();
        let axes = channels(s, &m);
        if axes != self.state.axes {
            self.events.push(InputEvent::Axes(axes.clone()));
            self.state.apply(&InputEvent::Axes(axes));
        }
        for (button, down) in [
            (s.grab_button, m.grab),
            (s.teleport_button, m.teleport),
            (s.mode_button, m.mode),
        ] {
            if let Some(index) = button
                && self.state.held(Some(index)) != down
            {
                let e = InputEvent::Button {
                    index: index as u32,
                    pressed: down,
                };
                self.state.apply(&e);
                self.events.push(e);
            }
        }
    }

    /// The desk's state for this frame (its press counts and time steps start again from
    /// zero after) and the changes as events.
    pub fn take(&mut self) -> (InputState, Vec<InputEvent>) {
        let state = self.state.clone();
        self.state.presses.iter_mut().for_each(|p| *p = 0);
        self.state.time_step_min = 0;
        (state, std::mem::take(&mut self.events))
    }
}

/// The desk's axes on the config's channels, in the device's own sign (so that
/// `shaped(..) * sign` reads them back as +1 forward, +1 right).
fn channels(s: &Navigation, m: &DeskInput) -> Vec<f64> {
    let mut axes = vec![0.0; s.forward_axis.max(s.turn_axis) + 1];
    axes[s.turn_axis] = f64::from(m.turn) * s.turn_sign;
    axes[s.forward_axis] = f64::from(m.forward) * s.forward_sign;
    axes
}

/// The devices' state and the desk's together: an axis is the desk's when it is
/// non-neutral, else the devices'; buttons are held by either, and presses add up.
pub fn combine(devices: &InputState, desk: &InputState) -> InputState {
    let mut out = devices.clone();
    for (i, &v) in desk.axes.iter().enumerate() {
        if v != 0.0 {
            if out.axes.len() <= i {
                out.axes.resize(i + 1, 0.0);
            }
            out.axes[i] = v;
        }
    }
    let n = out.buttons.len().max(desk.buttons.len());
    out.buttons.resize(n, false);
    out.presses.resize(n, 0);
    for (i, &b) in desk.buttons.iter().enumerate() {
        out.buttons[i] |= b;
        out.presses[i] += desk.presses.get(i).copied().unwrap_or(0);
    }
    out.time_step_min += desk.time_step_min;
    out
}
