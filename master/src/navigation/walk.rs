//! Walk: the joystick moves the user along the floor in the wand's horizontal direction,
//! stopped a radius short of walls, and the floor's height under the user is followed
//! (steps up to the step height, drops down to the deepest drop).

use glam::DVec3;
use holocave_scene::Scene;

use super::body::{Body, floor_under, travel};
use super::placement::{Placement, horizontal};

/// Moves the user whose feet are at `feet` (room) by `speed` m/s (negative: backwards) for
/// `dt` s along the horizontal part of `heading` (room); with a scene, walls stop it at
/// the body's radius.
pub fn walk(
    place: &mut Placement,
    heading: DVec3,
    feet: DVec3,
    speed: f64,
    dt: f64,
    scene: Option<&Scene>,
    body: Body,
) {
    let Some(h) = horizontal(place.dir(heading)) else {
        return;
    };
    let wanted = h * (speed * dt);
    let moved = match scene {
        Some(s) => travel(s, place.point(feet), wanted, body.radius, body.step_height),
        None => wanted,
    };
    place.shift(moved);
}

/// Puts the room's floor on the scene's floor under `feet` (room), if there is one within
/// `step_height` above and `max_drop` below.
pub fn follow_floor(
    place: &mut Placement,
    feet: DVec3,
    scene: &Scene,
    step_height: f64,
    max_drop: f64,
) {
    let at = place.point(feet);
    if let Some(y) = floor_under(scene, at, step_height, max_drop) {
        place.shift(DVec3::Y * (y - at.y));
    }
}
