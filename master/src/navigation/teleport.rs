//! Teleport: point the wand, press, and stand on the floor where it points (on a wall: on
//! the floor at its foot, a radius back toward the user).

use glam::DVec3;
use holocave_scene::Scene;

use super::body::{floor_under, pick};
use super::input::WandPose;
use super::placement::{Placement, horizontal};

/// A surface whose normal is within 45° of up is floor.
const FLOOR_COS: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// Where the wand points on the floor (scene), within `range`.
pub fn target(
    place: &Placement,
    wand: &WandPose,
    scene: &Scene,
    range: f64,
    radius: f64,
) -> Option<DVec3> {
    let origin = place.point(wand.position);
    let dir = place.dir(wand.forward()).normalize();
    let (hit, normal) = pick(scene, origin, dir, range)?;
    if normal.y >= FLOOR_COS {
        return Some(hit);
    }
    let back = hit - horizontal(dir)? * radius;
    let y = floor_under(scene, back, 0.0, range)?;
    Some(DVec3::new(back.x, y, back.z))
}

/// Moves the user whose feet are at `feet` (room) to stand at the floor the wand points
/// at; false when it points at no floor within `range` (nothing moves).
pub fn teleport(
    place: &mut Placement,
    wand: &WandPose,
    feet: DVec3,
    scene: &Scene,
    range: f64,
    radius: f64,
) -> bool {
    let Some(to) = target(place, wand, scene, range, radius) else {
        return false;
    };
    let at = place.point(feet);
    place.shift(to - at);
    true
}
