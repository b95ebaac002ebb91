//! Input devices besides the head: button and joystick events, as a VRPN server or a
//! session log delivers them, each with its time (the device's clock, like a tracker
//! sample's). A wand's pose is an ordinary tracker [`crate::Sample`].

use chrono::NaiveDateTime;

/// The form of a time of day in a session log (the site's local standard time, to the
/// minute: `2026-06-21T14:30`).
pub const TIME_FORMAT: &str = "%Y-%m-%dT%H:%M";

/// One event of a button box or a joystick, or the time of day set.
#[derive(Clone, Debug, PartialEq)]
pub enum InputEvent {
    /// Button `index` went down (`true`) or up.
    Button { index: u32, pressed: bool },
    /// Every button's state at once (VRPN's `vrpn_Button States`), button 0 first.
    Buttons(Vec<bool>),
    /// Every axis channel's value at once (VRPN's `vrpn_Analog Channel`), channel 0 first.
    Axes(Vec<f64>),
    /// The scene's time of day set (a replayed session's `time` row), in the site's local
    /// standard time.
    Time(NaiveDateTime),
}

/// An input event and its time (ns).
#[derive(Clone, Debug, PartialEq)]
pub struct InputSample {
    pub t_ns: u64,
    pub event: InputEvent,
}

impl InputSample {
    pub fn new(t_ns: u64, event: InputEvent) -> Self {
        InputSample { t_ns, event }
    }
}
