//! The config's `[navigation]` section: where the room starts in the scene (the
//! room → scene transform), the input devices that move it (a tracked wand, VRPN buttons
//! and joystick axes), which button and axis does what, and the speeds and comfort limits
//! of travel. [`NavigationSection`] is the section as written; [`Navigation`] the checked
//! settings the master's navigation runs on.

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::config::RigidTransform;

/// How the joystick moves the user.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum TravelMode {
    /// Along the floor in the wand's horizontal direction, following the floor's height
    /// and stopped by walls.
    #[default]
    Walk,
    /// Along the wand's direction, up and down included, no gravity (walls still stop).
    Fly,
    /// The joystick does not move the user (grab, turn and teleport still work).
    None,
}

/// The `[navigation]` section as written. Every key but the start transform has a default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NavigationSection {
    /// Room → scene at the start: where the room's origin sits in the scene.
    pub translation: [f64; 3],
    /// Its rotation, a unit quaternion `x, y, z, w`.
    pub rotation: [f64; 4],
    /// The joystick's travel mode.
    pub mode: TravelMode,
    /// The wand: a tracker sensor (`vrpn://Wand0@host#1`, `file:session.csv`).
    pub wand: Option<String>,
    /// The wand's buttons (`vrpn://Buttons0@host`, `file:session.csv`).
    pub buttons: Option<String>,
    /// The joystick's axes (`vrpn://Joystick0@host`, `file:session.csv`).
    pub axes: Option<String>,
    /// Walking speed at full deflection (m/s).
    pub walk_speed: f64,
    /// Flying speed at full deflection (m/s).
    pub fly_speed: f64,
    /// Turning rate at full deflection (degrees per second).
    pub turn_rate: f64,
    /// The axis channel that moves forward (+1: forward).
    pub forward_axis: usize,
    /// The axis channel that turns (+1: to the right).
    pub turn_axis: usize,
    /// Multiplies the forward axis (−1 for joysticks whose forward is negative).
    pub forward_sign: f64,
    /// Multiplies the turn axis.
    pub turn_sign: f64,
    /// Axis values closer to zero than this are zero; the rest is rescaled to reach 1.
    pub dead_zone: f64,
    /// The button that grabs the world while held; `-1`: none.
    pub grab_button: i64,
    /// The button that teleports to the floor the wand points at; `-1`: none.
    pub teleport_button: i64,
    /// The button that picks up the moving object the wand points at and carries it
    /// while held; `-1`: none.
    pub object_button: i64,
    /// The button that switches walking and flying at each press; `-1`: none.
    pub mode_button: i64,
    /// The buttons that step the scene's time of day by `time_step_min` earlier and
    /// later at each press; `-1`: none.
    pub earlier_button: i64,
    pub later_button: i64,
    /// Minutes a press of the earlier or later button steps the time of day.
    pub time_step_min: i64,
    /// Grabbing turns the world about the vertical only (no pitch, no roll).
    pub grab_yaw_only: bool,
    /// How close the user's body comes to a wall (m).
    pub radius: f64,
    /// The highest step walking climbs (m); higher is a wall.
    pub step_height: f64,
    /// The deepest drop walking follows in one frame (m); deeper is a hole the user stays
    /// above.
    pub max_drop: f64,
    /// The farthest teleport (m).
    pub teleport_range: f64,
    /// The rooms the user may walk into, as holodeck sections besides the CAVE's: boxes
    /// `[x0, y0, z0, x1, y1, z1]` in scene metres (`holocave holodeck sections` proposes
    /// them; `--section` on the command line takes their place).
    pub sections: Vec<[f64; 6]>,
}

impl Default for NavigationSection {
    fn default() -> Self {
        let start = RigidTransform::default();
        NavigationSection {
            translation: start.translation,
            rotation: start.rotation,
            mode: TravelMode::Walk,
            wand: None,
            buttons: None,
            axes: None,
            walk_speed: 1.4,
            fly_speed: 3.0,
            turn_rate: 45.0,
            forward_axis: 1,
            turn_axis: 0,
            forward_sign: 1.0,
            turn_sign: 1.0,
            dead_zone: 0.1,
            grab_button: 0,
            teleport_button: 1,
            object_button: 2,
            mode_button: 3,
            earlier_button: -1,
            later_button: -1,
            time_step_min: 60,
            grab_yaw_only: true,
            radius: 0.3,
            step_height: 0.35,
            max_drop: 2.0,
            teleport_range: 50.0,
            sections: Vec::new(),
        }
    }
}

impl NavigationSection {
    /// The start transform as written.
    pub fn start(&self) -> RigidTransform {
        RigidTransform {
            translation: self.translation,
            rotation: self.rotation,
        }
    }
}

/// Checked navigation settings (angles in radians).
#[derive(Clone, Debug, PartialEq)]
pub struct Navigation {
    pub mode: TravelMode,
    pub wand: Option<String>,
    pub buttons: Option<String>,
    pub axes: Option<String>,
    pub walk_speed: f64,
    pub fly_speed: f64,
    /// Radians per second.
    pub turn_rate: f64,
    pub forward_axis: usize,
    pub turn_axis: usize,
    pub forward_sign: f64,
    pub turn_sign: f64,
    pub dead_zone: f64,
    pub grab_button: Option<usize>,
    pub teleport_button: Option<usize>,
    pub object_button: Option<usize>,
    pub mode_button: Option<usize>,
    pub earlier_button: Option<usize>,
    pub later_button: Option<usize>,
    pub time_step_min: i64,
    pub grab_yaw_only: bool,
    pub radius: f64,
    pub step_height: f64,
    pub max_drop: f64,
    pub teleport_range: f64,
    /// Holodeck sections besides the CAVE's: `[lo, hi]` in scene metres.
    pub sections: Vec<[DVec3; 2]>,
}

impl Default for Navigation {
    fn default() -> Self {
        check(&NavigationSection::default(), &mut Vec::new())
    }
}

/// Checks the section; each problem names its key (`navigation.KEY`).
pub fn check(s: &NavigationSection, problems: &mut Vec<String>) -> Navigation {
    check_amounts(s, problems);
    let [grab_button, teleport_button, object_button, mode_button] = check_buttons(s, problems);
    let [earlier_button, later_button] = check_time_buttons(s, problems);
    check_axes(s, problems);
    let sections = check_sections(s, problems);
    Navigation {
        mode: s.mode,
        wand: s.wand.clone(),
        buttons: s.buttons.clone(),
        axes: s.axes.clone(),
        walk_speed: s.walk_speed,
        fly_speed: s.fly_speed,
        turn_rate: s.turn_rate.to_radians(),
        forward_axis: s.forward_axis,
        turn_axis: s.turn_axis,
        forward_sign: s.forward_sign,
        turn_sign: s.turn_sign,
        dead_zone: s.dead_zone,
        grab_button,
        teleport_button,
        object_button,
        mode_button,
        earlier_button,
        later_button,
        time_step_min: s.time_step_min,
        grab_yaw_only: s.grab_yaw_only,
        radius: s.radius,
        step_height: s.step_height,
        max_drop: s.max_drop,
        teleport_range: s.teleport_range,
        sections,
    }
}

/// The speeds, distances, dead zone and signs.
fn check_amounts(s: &NavigationSection, problems: &mut Vec<String>) {
    let mut positive = |key: &str, v: f64, max: f64| {
        if !(v > 0.0 && v <= max) {
            problems.push(format!(
                "navigation.{key}: {v} must be positive and at most {max}"
            ));
        }
    };
    positive("walk_speed", s.walk_speed, 100.0);
    positive("fly_speed", s.fly_speed, 1000.0);
    positive("turn_rate", s.turn_rate, 720.0);
    positive("radius", s.radius, 10.0);
    positive("step_height", s.step_height, 10.0);
    positive("max_drop", s.max_drop, 1000.0);
    positive("teleport_range", s.teleport_range, 1e5);
    if !(0.0..0.9).contains(&s.dead_zone) {
        problems.push(format!(
            "navigation.dead_zone: {} must be in [0, 0.9)",
            s.dead_zone
        ));
    }
    for (key, v) in [("forward_sign", s.forward_sign), ("turn_sign", s.turn_sign)] {
        if v != 1.0 && v != -1.0 {
            problems.push(format!("navigation.{key}: {v} must be 1 or -1"));
        }
    }
}

/// Button `b` of key `key` (`None` for -1), or a problem naming the key.
fn button(key: &str, b: i64, problems: &mut Vec<String>) -> Option<usize> {
    match b {
        -1 => None,
        0..=255 => Some(b as usize),
        _ => {
            problems.push(format!(
                "navigation.{key}: {b} is not a button (0 to 255, or -1 for none)"
            ));
            None
        }
    }
}

/// The earlier and later buttons (`None`: none), each a button of its own, and the step.
fn check_time_buttons(s: &NavigationSection, problems: &mut Vec<String>) -> [Option<usize>; 2] {
    let earlier = button("earlier_button", s.earlier_button, problems);
    let later = button("later_button", s.later_button, problems);
    let taken = [
        s.grab_button,
        s.teleport_button,
        s.object_button,
        s.mode_button,
    ];
    for (key, b, v) in [
        ("earlier_button", earlier, s.earlier_button),
        ("later_button", later, s.later_button),
    ] {
        if b.is_some() && taken.contains(&v) {
            problems.push(format!(
                "navigation.{key}: {v} is also the grab, teleport, object or mode button"
            ));
        }
    }
    if earlier.is_some() && earlier == later {
        problems.push(format!(
            "navigation.later_button: {} is also the earlier button",
            s.later_button
        ));
    }
    if !(1..=7 * 24 * 60).contains(&s.time_step_min) {
        problems.push(format!(
            "navigation.time_step_min: {} must be 1 to 10080 (a week)",
            s.time_step_min
        ));
    }
    [earlier, later]
}

/// The grab, teleport, object and mode buttons (`None`: none), each a button and no two
/// the same.
fn check_buttons(s: &NavigationSection, problems: &mut Vec<String>) -> [Option<usize>; 4] {
    let mut button = |key: &str, b: i64| button(key, b, problems);
    let grab_button = button("grab_button", s.grab_button);
    let teleport_button = button("teleport_button", s.teleport_button);
    let object_button = button("object_button", s.object_button);
    let mode_button = button("mode_button", s.mode_button);
    if mode_button.is_some() && [grab_button, teleport_button, object_button].contains(&mode_button)
    {
        problems.push(format!(
            "navigation.mode_button: {} is also the grab, teleport or object button",
            s.mode_button
        ));
    }
    if object_button.is_some() && (object_button == grab_button || object_button == teleport_button)
    {
        problems.push(format!(
            "navigation.object_button: {} is also the grab or the teleport button",
            s.object_button
        ));
    }
    if grab_button.is_some() && grab_button == teleport_button {
        problems.push(format!(
            "navigation.teleport_button: {} is also the grab button",
            s.teleport_button
        ));
    }
    [grab_button, teleport_button, object_button, mode_button]
}

/// The forward and turn axes: channels, and not the same one.
fn check_axes(s: &NavigationSection, problems: &mut Vec<String>) {
    for (key, a) in [("forward_axis", s.forward_axis), ("turn_axis", s.turn_axis)] {
        if a > 127 {
            problems.push(format!(
                "navigation.{key}: {a} is not an axis channel (0 to 127)"
            ));
        }
    }
    if s.forward_axis == s.turn_axis {
        problems.push(format!(
            "navigation.turn_axis: {} is also the forward axis",
            s.turn_axis
        ));
    }
}

/// The holodeck sections besides the CAVE's, each a finite box.
fn check_sections(s: &NavigationSection, problems: &mut Vec<String>) -> Vec<[DVec3; 2]> {
    let mut sections = Vec::new();
    for (i, b) in s.sections.iter().enumerate() {
        let (lo, hi) = (DVec3::new(b[0], b[1], b[2]), DVec3::new(b[3], b[4], b[5]));
        if lo.is_finite() && hi.is_finite() && lo.cmplt(hi).all() {
            sections.push([lo, hi]);
        } else {
            problems.push(format!(
                "navigation.sections[{i}]: {b:?} is not a box (x0, y0, z0 below x1, y1, z1, finite)"
            ));
        }
    }
    sections
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_a_walking_user_and_every_bad_key_is_named() {
        let n = Navigation::default();
        assert_eq!((n.walk_speed, n.mode), (1.4, TravelMode::Walk));
        assert!((n.turn_rate - 45f64.to_radians()).abs() < 1e-15);
        assert!(n.grab_yaw_only, "no roll by default");
        let s: NavigationSection = toml::from_str(
            "walk_speed = -1.0\ngrab_button = 1\nteleport_button = 1\ndead_zone = 2.0\nforward_sign = 0.5\nmode_button = 2\nsections = [[0, 0, 0, 1, 2, 3], [0, 0, 0, 1, -2, 3]]",
        )
        .unwrap();
        let mut problems = Vec::new();
        check(&s, &mut problems);
        let all = problems.join("\n");
        for key in [
            "navigation.walk_speed",
            "navigation.teleport_button",
            "navigation.dead_zone",
            "navigation.forward_sign",
            "navigation.mode_button",
            "navigation.sections[1]",
        ] {
            assert!(all.contains(key), "{key} not named in:\n{all}");
        }
        assert_eq!(problems.len(), 6, "{all}");
        let s: NavigationSection =
            toml::from_str("earlier_button = 0\nlater_button = 9\ntime_step_min = 0").unwrap();
        let mut problems = Vec::new();
        check(&s, &mut problems);
        let all = problems.join("\n");
        assert!(
            all.contains("navigation.earlier_button: 0 is also the grab"),
            "{all}"
        );
        assert!(all.contains("navigation.time_step_min: 0"), "{all}");
        assert_eq!(problems.len(), 2, "{all}");
        let s: NavigationSection = toml::from_str("sections = [[0, 0, 0, 1, 2, 3]]").unwrap();
        let n = check(&s, &mut problems);
        assert_eq!(n.sections, vec![[DVec3::ZERO, DVec3::new(1.0, 2.0, 3.0)]]);
    }
}
