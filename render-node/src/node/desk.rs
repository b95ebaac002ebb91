//! A desk user's keyboard and mouse in a node's window, turned into the navigation the
//! master integrates ([`DeskInput`]: the joystick's forward and turn axes, the grab,
//! teleport and walk/fly buttons). The node computes nothing from it; it sends each change
//! to the master. Keys are taken by their place on the keyboard (W/A/S/D on any layout):
//!
//! | key | input |
//! |---|---|
//! | W, ↑ / S, ↓ | forward / back (forward axis ±1) |
//! | A, ←, Q / D, →, E | turn left / right (turn axis ±1) |
//! | left mouse button dragged | steer: up/down forward/back, left/right turn, full at [`DRAG_FULL`] pixels from the press |
//! | Space | teleport (a tap counts) |
//! | G, right mouse button | grab (held) |
//! | F | walk ↔ fly |
//! | [ / ] | the time of day 15 min earlier / later |
//! | - / = | 1 h earlier / later |
//! | , / . | 1 day earlier / later |
//!
//! A key's axis wins over the drag's. Losing the focus releases everything.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex};

use holocave_protocol::cluster::{DeskInput, MAX_TIME_STEP_MIN};
use winit::keyboard::KeyCode;

/// Drag distance (pixels) for a full deflection.
pub const DRAG_FULL: f64 = 200.0;
/// Most changes kept between two frames of the node; beyond it, axis changes replace the
/// last one.
pub const MAX_PENDING: usize = 64;

/// What a key does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Control {
    Forward,
    Back,
    Left,
    Right,
    Grab,
    Teleport,
    Mode,
}

/// The key at `code`'s place, if it navigates.
pub fn control_of(code: KeyCode) -> Option<Control> {
    use KeyCode::*;
    Some(match code {
        KeyW | ArrowUp => Control::Forward,
        KeyS | ArrowDown => Control::Back,
        KeyA | ArrowLeft | KeyQ => Control::Left,
        KeyD | ArrowRight | KeyE => Control::Right,
        KeyG => Control::Grab,
        Space => Control::Teleport,
        KeyF => Control::Mode,
        _ => return None,
    })
}

/// The minutes the key at `code`'s place steps the time of day, if it is a time key.
pub fn time_step_of(code: KeyCode) -> Option<i32> {
    use KeyCode::*;
    Some(match code {
        BracketLeft => -15,
        BracketRight => 15,
        Minus => -60,
        Equal => 60,
        Comma => -24 * 60,
        Period => 24 * 60,
        _ => return None,
    })
}

/// Keys held, the mouse's drag. A control is on while any of its keys is held.
#[derive(Clone, Debug, Default)]
pub struct DeskKeys {
    /// Each held key once: a press of a key already down (an auto-repeat the window
    /// system did not mark as one: Xvfb's, through XTEST) changes nothing, and its one
    /// release lets it go.
    held: Vec<KeyCode>,
    cursor: Option<(f64, f64)>,
    drag_from: Option<(f64, f64)>,
    right_button: bool,
    /// Minutes the time keys stepped since the input was last sent.
    time_step_min: i32,
}

impl DeskKeys {
    /// The key at `code`'s place went down or up.
    pub fn key(&mut self, code: KeyCode, down: bool) {
        if !down {
            self.held.retain(|&k| k != code);
        } else if !self.held.contains(&code) {
            if let Some(step) = time_step_of(code) {
                self.time_step_min =
                    (self.time_step_min + step).clamp(-MAX_TIME_STEP_MIN, MAX_TIME_STEP_MIN);
                self.held.push(code);
            } else if control_of(code).is_some() {
                self.held.push(code);
            }
        }
    }

    pub fn cursor(&mut self, x: f64, y: f64) {
        self.cursor = Some((x, y));
    }

    /// The left button starts and ends a drag where the cursor is.
    pub fn left_button(&mut self, down: bool) {
        self.drag_from = if down { self.cursor } else { None };
    }

    pub fn right_button(&mut self, down: bool) {
        self.right_button = down;
    }

    /// The window lost the focus: nothing is held any more.
    pub fn release_all(&mut self) {
        *self = DeskKeys {
            cursor: self.cursor,
            ..DeskKeys::default()
        };
    }

    fn on(&self, c: Control) -> bool {
        self.held.iter().any(|&k| control_of(k) == Some(c))
    }

    fn keys_axis(&self, plus: Control, minus: Control) -> f32 {
        f32::from(u8::from(self.on(plus))) - f32::from(u8::from(self.on(minus)))
    }

    /// The navigation this asks for.
    pub fn input(&self) -> DeskInput {
        let (mut drag_forward, mut drag_turn) = (0.0, 0.0);
        if let (Some((x0, y0)), Some((x, y))) = (self.drag_from, self.cursor) {
            let deflection = |d: f64| (d / DRAG_FULL).clamp(-1.0, 1.0) as f32;
            drag_forward = deflection(y0 - y);
            drag_turn = deflection(x - x0);
        }
        let or = |key: f32, drag: f32| if key != 0.0 { key } else { drag };
        DeskInput {
            forward: or(
                self.keys_axis(Control::Forward, Control::Back),
                drag_forward,
            ),
            turn: or(self.keys_axis(Control::Right, Control::Left), drag_turn),
            grab: self.on(Control::Grab) || self.right_button,
            teleport: self.on(Control::Teleport),
            mode: self.on(Control::Mode),
            time_step_min: self.time_step_min,
        }
    }
}

/// The window's keys, shared by the event loop (which updates them) and the frame loop
/// (which sends each change to the master): every button edge is kept (so a tap shorter
/// than a frame is sent), a change of the axes alone replaces the one before it.
#[derive(Clone, Debug, Default)]
pub struct DeskFeed(Arc<Mutex<Shared>>);

#[derive(Debug, Default)]
struct Shared {
    keys: DeskKeys,
    last: DeskInput,
    pending: VecDeque<DeskInput>,
}

/// Whether `a` and `b` differ in their axes alone (a time step counts as a button).
fn same_buttons(a: &DeskInput, b: &DeskInput) -> bool {
    (a.grab, a.teleport, a.mode, a.time_step_min) == (b.grab, b.teleport, b.mode, b.time_step_min)
}

impl DeskFeed {
    /// Changes the keys; queues the input when it changed.
    pub fn update(&self, f: impl FnOnce(&mut DeskKeys)) {
        let mut s = self.0.lock().unwrap_or_else(|e| e.into_inner());
        f(&mut s.keys);
        let now = s.keys.input();
        // A time step is sent once.
        s.keys.time_step_min = 0;
        if now == s.last {
            return;
        }
        let last = s.last;
        s.last = now;
        let full = s.pending.len() >= MAX_PENDING;
        match s.pending.back_mut() {
            Some(b) if full || (same_buttons(b, &now) && same_buttons(&last, &now)) => {
                let steps = b.time_step_min.saturating_add(now.time_step_min);
                *b = DeskInput {
                    time_step_min: steps.clamp(-MAX_TIME_STEP_MIN, MAX_TIME_STEP_MIN),
                    ..now
                };
            }
            _ => s.pending.push_back(now),
        }
    }

    /// The changes since the last call, oldest first.
    pub fn take(&self) -> Vec<DeskInput> {
        let mut s = self.0.lock().unwrap_or_else(|e| e.into_inner());
        s.pending.drain(..).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn press(k: &mut DeskKeys, code: KeyCode, down: bool) {
        k.key(code, down);
    }

    #[test]
    fn keys_map_onto_the_joysticks_axes_and_the_buttons() {
        let mut k = DeskKeys::default();
        assert_eq!(k.input(), DeskInput::NEUTRAL);
        press(&mut k, KeyCode::KeyW, true);
        press(&mut k, KeyCode::ArrowLeft, true);
        let i = k.input();
        assert_eq!((i.forward, i.turn), (1.0, -1.0));
        // W and ↑ together are one forward; letting one go keeps it.
        press(&mut k, KeyCode::ArrowUp, true);
        press(&mut k, KeyCode::KeyW, false);
        assert_eq!(k.input().forward, 1.0);
        // Forward and back together cancel.
        press(&mut k, KeyCode::KeyS, true);
        assert_eq!(k.input().forward, 0.0);
        press(&mut k, KeyCode::KeyE, true);
        assert_eq!(k.input().turn, 0.0);
        press(&mut k, KeyCode::Space, true);
        press(&mut k, KeyCode::KeyG, true);
        press(&mut k, KeyCode::KeyF, true);
        let i = k.input();
        assert!(i.teleport && i.grab && i.mode, "{i:?}");
        assert_eq!(control_of(KeyCode::KeyZ), None);
        k.release_all();
        assert_eq!(k.input(), DeskInput::NEUTRAL);
    }

    #[test]
    fn time_keys_step_the_time_once_per_press_and_the_feed_sends_each_step_once() {
        let feed = DeskFeed::default();
        feed.update(|k| k.key(KeyCode::Equal, true));
        // An unmarked auto-repeat of a key already down steps nothing.
        feed.update(|k| k.key(KeyCode::Equal, true));
        feed.update(|k| k.key(KeyCode::Equal, false));
        feed.update(|k| k.key(KeyCode::BracketLeft, true));
        feed.update(|k| k.key(KeyCode::KeyW, true));
        let sent = feed.take();
        let steps: Vec<i32> = sent.iter().map(|d| d.time_step_min).collect();
        assert_eq!(steps.iter().sum::<i32>(), 60 - 15, "{sent:?}");
        assert_eq!(steps.iter().filter(|&&s| s != 0).count(), 2, "{sent:?}");
        assert_eq!(sent.last().unwrap().forward, 1.0);
        // Past the queue's bound the taps add up in its last message, a week at most.
        for _ in 0..100 {
            feed.update(|k| k.key(KeyCode::Comma, true));
            feed.update(|k| k.key(KeyCode::Comma, false));
        }
        let sent = feed.take();
        assert!(sent.len() <= MAX_PENDING);
        assert!(sent.iter().all(|d| d.validate().is_ok()));
        let total: i32 = sent.iter().map(|d| d.time_step_min).sum();
        assert!((-100 * 24 * 60..-31 * 24 * 60).contains(&total), "{total}");
    }

    #[test]
    fn a_key_pressed_again_while_down_is_let_go_by_one_release() {
        let mut k = DeskKeys::default();
        for _ in 0..5 {
            press(&mut k, KeyCode::KeyW, true);
        }
        assert_eq!(k.input().forward, 1.0);
        press(&mut k, KeyCode::KeyW, false);
        assert_eq!(k.input(), DeskInput::NEUTRAL);
        // A release of a key never pressed (pressed before the focus came) is nothing.
        press(&mut k, KeyCode::KeyS, false);
        assert_eq!(k.input(), DeskInput::NEUTRAL);
    }

    #[test]
    fn a_drag_steers_in_proportion_and_keys_win() {
        let mut k = DeskKeys::default();
        k.cursor(300.0, 300.0);
        k.cursor(350.0, 300.0); // moving without a press does nothing
        assert_eq!(k.input(), DeskInput::NEUTRAL);
        k.left_button(true);
        k.cursor(400.0, 200.0); // 50 px right, 100 px up of the press
        let i = k.input();
        assert_eq!((i.forward, i.turn), (0.5, 0.25));
        k.cursor(-1000.0, 2000.0);
        let i = k.input();
        assert_eq!((i.forward, i.turn), (-1.0, -1.0));
        press(&mut k, KeyCode::KeyW, true);
        assert_eq!(k.input().forward, 1.0);
        k.left_button(false);
        assert_eq!(k.input().turn, 0.0);
        k.right_button(true);
        assert!(k.input().grab);
    }

    #[test]
    fn the_feed_keeps_every_tap_and_coalesces_axis_motion() {
        let feed = DeskFeed::default();
        feed.update(|k| k.cursor(0.0, 0.0));
        assert!(feed.take().is_empty(), "no change, nothing sent");
        feed.update(|k| k.left_button(true));
        for x in 1..500 {
            feed.update(|k| k.cursor(f64::from(x), 0.0));
        }
        feed.update(|k| k.key(KeyCode::Space, true));
        feed.update(|k| k.key(KeyCode::Space, false));
        let sent = feed.take();
        // The drag's motion as one change (its last), the tap down and up.
        assert_eq!(sent.len(), 3, "{sent:?}");
        assert_eq!(sent[0].turn, 1.0);
        assert!(sent[1].teleport && !sent[2].teleport);
        // Bounded however many taps come between two frames.
        for _ in 0..1000 {
            feed.update(|k| k.key(KeyCode::KeyF, true));
            feed.update(|k| k.key(KeyCode::KeyF, false));
        }
        let sent = feed.take();
        assert!(sent.len() <= MAX_PENDING);
        assert_eq!(*sent.last().unwrap(), feed.0.lock().unwrap().last);
    }
}
