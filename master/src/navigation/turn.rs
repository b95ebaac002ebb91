//! Turn: the world turns about the vertical through the user's head, so the user turns in
//! place (no pitch, no roll).

use glam::{DQuat, DVec3};

use super::placement::Placement;

/// Turns the user by `rate` rad/s (positive: to the right, clockwise seen from above) for
/// `dt` seconds about the vertical through `head` (room coordinates).
pub fn turn(place: &mut Placement, head: DVec3, rate: f64, dt: f64) {
    let pivot = place.point(head);
    // The room's directions turn clockwise in the scene: a rotation of −angle about +Y.
    place.turn_about(pivot, DQuat::from_rotation_y(-rate * dt));
}
