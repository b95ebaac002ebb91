//! Fly: the joystick moves the user along the wand's direction, up and down included, with
//! no gravity; walls still stop the user at the radius.

use glam::DVec3;
use holocave_scene::Scene;

use super::body::{Body, travel};
use super::placement::Placement;

/// Moves the user whose feet are at `feet` (room) by `speed` m/s along `dir` (room, any
/// length but zero) for `dt` s.
pub fn fly(
    place: &mut Placement,
    dir: DVec3,
    feet: DVec3,
    speed: f64,
    dt: f64,
    scene: Option<&Scene>,
    body: Body,
) {
    let d = place.dir(dir).normalize_or_zero();
    let wanted = d * (speed * dt);
    let moved = match scene {
        Some(s) => travel(s, place.point(feet), wanted, body.radius, body.step_height),
        None => wanted,
    };
    place.shift(moved);
}
