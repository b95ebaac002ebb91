//! The input devices as the navigation sees them each frame: the wand's pose in room
//! coordinates, the buttons held (and pressed since the last frame) and the joystick's
//! axes. [`Inputs`] reads the devices up to a frame's time on the master's clock, the way
//! the head is read: live, whatever has arrived; on a replay clock, every event whose time
//! since the start of its log has come, so the same log gives the same states.

use std::time::{Duration, Instant};

use chrono::NaiveDateTime;

use glam::{DMat4, DQuat, DVec3};
use holocave_tracking::Sample;
use holocave_tracking::input::{InputEvent, InputSample};
use holocave_tracking::input_source::{InputSource, NextInput};
use holocave_tracking::source::{Next, TrackerSource};

use crate::head::Clock;

/// A wand's pose in room coordinates (f64).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WandPose {
    pub position: DVec3,
    pub orientation: DQuat,
}

impl WandPose {
    /// Where the wand points (its −Z axis), room coordinates.
    pub fn forward(&self) -> DVec3 {
        self.orientation * DVec3::NEG_Z
    }
}

/// The input devices' state at a frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct InputState {
    /// The newest wand pose (`None` before the first).
    pub wand: Option<WandPose>,
    /// Buttons held.
    pub buttons: Vec<bool>,
    /// Per button, how often it went down since the last frame (a click shorter than a
    /// frame still counts).
    pub presses: Vec<u32>,
    /// Joystick channels, as the device sends them (usually −1..1).
    pub axes: Vec<f64>,
    /// The time of day a device set since the last frame (a replayed `time` row; the
    /// latest wins).
    pub time_set: Option<NaiveDateTime>,
    /// Minutes the desk's keys stepped the time of day since the last frame.
    pub time_step_min: i64,
}

impl InputState {
    pub fn held(&self, button: Option<usize>) -> bool {
        button.is_some_and(|b| self.buttons.get(b).copied().unwrap_or(false))
    }

    pub fn pressed(&self, button: Option<usize>) -> bool {
        button.is_some_and(|b| self.presses.get(b).copied().unwrap_or(0) > 0)
    }

    pub fn axis(&self, channel: usize) -> f64 {
        self.axes.get(channel).copied().unwrap_or(0.0)
    }

    fn set_button(&mut self, index: usize, pressed: bool) {
        if self.buttons.len() <= index {
            self.buttons.resize(index + 1, false);
            self.presses.resize(index + 1, 0);
        }
        if pressed && !self.buttons[index] {
            self.presses[index] += 1;
        }
        self.buttons[index] = pressed;
    }

    /// Applies one event.
    pub fn apply(&mut self, event: &InputEvent) {
        match event {
            InputEvent::Button { index, pressed } => self.set_button(*index as usize, *pressed),
            InputEvent::Buttons(states) => {
                for (i, &s) in states.iter().enumerate() {
                    self.set_button(i, s);
                }
            }
            InputEvent::Axes(values) => self.axes.clone_from(values),
            InputEvent::Time(when) => self.time_set = Some(*when),
        }
    }
}

/// One device's reader: what it has read but not yet applied (replay: not due).
struct Feed<S, T> {
    source: S,
    pending: Option<T>,
    ended: bool,
}

fn feed<S, T>(source: S) -> Feed<S, T> {
    Feed {
        source,
        pending: None,
        ended: false,
    }
}

/// The wand, buttons and axes, read up to each frame's time.
pub struct Inputs {
    clock: Clock,
    wand: Option<Feed<Box<dyn TrackerSource>, Sample>>,
    wand_t0: Option<u64>,
    buttons: Option<Feed<InputSource, InputSample>>,
    axes: Option<Feed<InputSource, InputSample>>,
    tracker_to_room: DMat4,
    state: InputState,
    /// Events and wand samples read.
    pub read: u64,
}

impl Inputs {
    /// The devices given (any may be absent); the wand's poses are mapped to the room by
    /// `tracker_to_room`, as the head's are.
    pub fn new(
        clock: Clock,
        wand: Option<Box<dyn TrackerSource>>,
        buttons: Option<InputSource>,
        axes: Option<InputSource>,
        tracker_to_room: DMat4,
    ) -> Inputs {
        Inputs {
            clock,
            wand: wand.map(feed),
            wand_t0: None,
            buttons: buttons.map(feed),
            axes: axes.map(feed),
            tracker_to_room,
            state: InputState::default(),
            read: 0,
        }
    }

    /// True when no device is bound.
    pub fn is_empty(&self) -> bool {
        self.wand.is_none() && self.buttons.is_none() && self.axes.is_none()
    }

    fn deadline(&self) -> Instant {
        match self.clock {
            Clock::Live => Instant::now(),
            // Recorded sources answer at once; the margin only guards a synthetic
            // source's first call.
            Clock::Replay => Instant::now() + Duration::from_millis(100),
        }
    }

    /// The state once every event that has arrived by `now_ns` on the master's clock is
    /// applied; the press counts and the time set start again from nothing.
    pub fn advance(&mut self, now_ns: u64) -> &InputState {
        self.state.presses.iter_mut().for_each(|p| *p = 0);
        self.state.time_set = None;
        let deadline = self.deadline();
        let replay = self.clock == Clock::Replay;
        if let Some(feed) = &mut self.wand {
            loop {
                let s = match feed.pending.take() {
                    Some(s) => s,
                    None if feed.ended => break,
                    None => match feed.source.next(deadline) {
                        Next::Sample(s, _) => {
                            self.read += 1;
                            s
                        }
                        Next::Idle => break,
                        Next::End => {
                            feed.ended = true;
                            break;
                        }
                    },
                };
                let t0 = *self.wand_t0.get_or_insert(s.t_ns);
                if replay && s.t_ns - t0.min(s.t_ns) > now_ns {
                    feed.pending = Some(s);
                    break;
                }
                if s.pose.is_finite() && (s.pose.orientation.length() - 1.0).abs() < 1e-3 {
                    let m = self.tracker_to_room;
                    let q = DQuat::from_mat4(&m);
                    let o = s.pose.orientation.as_dquat().normalize();
                    self.state.wand = Some(WandPose {
                        position: m.transform_point3(s.pose.position.as_dvec3()),
                        orientation: (q * o).normalize(),
                    });
                }
            }
        }
        for feed in [&mut self.buttons, &mut self.axes].into_iter().flatten() {
            loop {
                let e = match feed.pending.take() {
                    Some(e) => e,
                    None if feed.ended => break,
                    None => match feed.source.next(deadline) {
                        NextInput::Event(e, _) => {
                            self.read += 1;
                            e
                        }
                        NextInput::Idle => break,
                        NextInput::End => {
                            feed.ended = true;
                            break;
                        }
                    },
                };
                // A recorded log's events are due at their own time (on either clock);
                // a live device's as they arrive.
                if !feed.source.endless() && e.t_ns > now_ns {
                    feed.pending = Some(e);
                    break;
                }
                self.state.apply(&e.event);
            }
        }
        &self.state
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::VecDeque;

    #[test]
    fn replayed_events_apply_at_their_time_and_a_short_click_still_counts() {
        let ev = |t, index, pressed| InputSample::new(t, InputEvent::Button { index, pressed });
        let events: VecDeque<_> = vec![
            ev(10, 0, true),
            ev(12, 0, false), // a click within one frame
            ev(30, 1, true),
        ]
        .into();
        let mut inputs = Inputs::new(
            Clock::Replay,
            None,
            Some(InputSource::Replay(events)),
            None,
            DMat4::IDENTITY,
        );
        let s = inputs.advance(5).clone();
        assert_eq!((s.buttons.len(), s.pressed(Some(0))), (0, false));
        let s = inputs.advance(20).clone();
        assert!(s.pressed(Some(0)) && !s.held(Some(0)), "{s:?}");
        let s = inputs.advance(40).clone();
        assert!(!s.pressed(Some(0)) && s.held(Some(1)) && s.pressed(Some(1)));
        let s = inputs.advance(50).clone();
        assert!(
            s.held(Some(1)) && !s.pressed(Some(1)),
            "pressed once, not every frame"
        );
    }
}
