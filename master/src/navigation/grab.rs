//! Grab the world: while the button is held, the world follows the wand, so the wand's
//! motion since the last frame moves the world with it (the scene point that was at the
//! wand stays at the wand). The navigator then keeps the body out of walls as walking does
//! (`Navigator::step`).

use super::input::WandPose;
use super::placement::{Placement, yaw_part};

/// Moves the world by the wand's motion from `before` to `now` (room coordinates); with
/// `yaw_only`, only the motion's turn about the vertical is kept (no pitch, no roll).
pub fn grab(place: &mut Placement, before: &WandPose, now: &WandPose, yaw_only: bool) {
    let q = now.orientation * before.orientation.inverse();
    let q = if yaw_only { yaw_part(q) } else { q.normalize() };
    // The room motion D: p ↦ q (p − before) + now, which takes the wand's old pose to its new
    // one; a scene point seen at room point p before is seen at D p after.
    let t = now.position - q * before.position;
    place.then_inverse_of(q, t);
}
