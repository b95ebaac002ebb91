//! The user's body against the scene, by rays through the scene's BVH: how far it can move
//! before coming within its radius of a surface, and the floor's height under it. The BVH
//! finds the triangle (in f32); the distance to it is then solved in f64 on the triangle's
//! plane, so a user standing still on a floor stays at exactly the same height.
//!
//! Only surfaces the rays along the motion meet are seen: a wall met at a grazing angle (its
//! normal more than [`MIN_APPROACH`]'s angle from the motion) is found only once it is
//! within reach of the ray, so the body may come closer to it than the radius (never through
//! it: the motion into it is then slid along it).

use glam::{DVec3, Vec3};
use holocave_scene::{Ray, Scene};

/// The rays that look for walls start just over the highest step and go up this far above
/// the feet (m), a head's height...
const BODY_TOP: f64 = 1.9;
/// ...every this many metres, so a table top or a lintel thinner than a hand stops the user
/// too (about 60 rays a frame: microseconds).
const BODY_SPACING: f64 = 0.025;

/// The smallest cosine between the motion and a wall's normal the rays look far enough
/// ahead for (about 87°).
pub const MIN_APPROACH: f64 = 0.05;

/// The hit of the ray `origin + t dir` with triangle `tri`'s plane, in f64: the distance
/// and the plane's normal facing back along the ray. `None` for a ray along the plane.
fn exact(scene: &Scene, tri: u32, origin: DVec3, dir: DVec3) -> Option<(f64, DVec3)> {
    let [a, b, c] = scene.triangle(tri).map(|v| v.as_dvec3());
    let mut n = (b - a).cross(c - a).normalize_or_zero();
    let along = n.dot(dir);
    if along.abs() < 1e-12 {
        return None;
    }
    let t = n.dot(a - origin) / along;
    if along > 0.0 {
        n = -n;
    }
    Some((t, n))
}

/// The body's size for collisions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Body {
    /// How close it comes to a wall (m).
    pub radius: f64,
    /// The highest step it climbs (m).
    pub step_height: f64,
}

/// What stops a motion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blocked {
    /// How far the body can go (m).
    pub free: f64,
    /// The surface's normal, facing the body.
    pub normal: DVec3,
}

fn ray(origin: DVec3, dir: DVec3) -> Ray {
    // `+ 0.0` turns a −0 direction component into +0 (see DESIGN's obvhs pitfall).
    Ray::new(origin.as_vec3(), dir.as_vec3() + Vec3::ZERO)
}

/// How far the body standing at `feet` may move along unit `dir` (at most `dist`): along
/// each ray, from the feet at a body height, until the body is `radius` from the plane of
/// the first surface the ray meets (measured along the surface's normal). `None`: nothing
/// in the way.
pub fn blocked(
    scene: &Scene,
    feet: DVec3,
    dir: DVec3,
    dist: f64,
    radius: f64,
    step_height: f64,
) -> Option<Blocked> {
    let low = step_height + 0.05;
    let n = ((BODY_TOP - low) / BODY_SPACING).ceil().max(0.0) as usize;
    (0..=n)
        .map(|k| (low + k as f64 * BODY_SPACING).min(BODY_TOP.max(low)))
        .filter_map(|h| {
            let origin = feet + DVec3::Y * h;
            let reach = dist + radius / MIN_APPROACH;
            let hit = scene.closest_hit(&ray(origin, dir), reach as f32)?;
            let (t, n) = exact(scene, hit.triangle, origin, dir)?;
            // The body is t·cos from the plane and closes in at cos per metre.
            let cos = -n.dot(dir);
            let free = (t - radius / cos).max(0.0);
            (free < dist).then_some(Blocked { free, normal: n })
        })
        .min_by(|a, b| a.free.total_cmp(&b.free))
}

/// The motion the body at `feet` makes of `wanted` (scene metres): stopped `radius` short
/// of a surface, and the rest slid once along it (walking into a wall at an angle follows
/// the wall; straight into it stops).
pub fn travel(scene: &Scene, feet: DVec3, wanted: DVec3, radius: f64, step_height: f64) -> DVec3 {
    let dist = wanted.length();
    if dist < 1e-12 {
        return DVec3::ZERO;
    }
    let dir = wanted / dist;
    let Some(b) = blocked(scene, feet, dir, dist, radius, step_height) else {
        return wanted;
    };
    let done = dir * b.free.min(dist);
    let rest = wanted - done;
    let slide = rest - b.normal * rest.dot(b.normal);
    let slide = DVec3::new(
        slide.x,
        if wanted.y == 0.0 { 0.0 } else { slide.y },
        slide.z,
    );
    let len = slide.length();
    if len < 1e-9 {
        return done;
    }
    let sdir = slide / len;
    let from = feet + done;
    let free = blocked(scene, from, sdir, len, radius, step_height).map_or(len, |b| b.free);
    done + sdir * free.min(len)
}

/// The floor's height under `feet`: the first surface a ray meets going down from
/// `step_height` above the feet, no deeper than `max_drop` below them. `None`: no floor
/// within reach (a hole, or outside the scene).
pub fn floor_under(scene: &Scene, feet: DVec3, step_height: f64, max_drop: f64) -> Option<f64> {
    let origin = feet + DVec3::Y * step_height;
    let hit = scene.closest_hit(&ray(origin, DVec3::NEG_Y), (step_height + max_drop) as f32)?;
    let (t, _) = exact(scene, hit.triangle, origin, DVec3::NEG_Y)?;
    Some(origin.y - t)
}

/// The first surface along a ray from `origin` along unit `dir` within `range`: the point
/// and the surface's normal facing back along the ray.
pub fn pick(scene: &Scene, origin: DVec3, dir: DVec3, range: f64) -> Option<(DVec3, DVec3)> {
    let hit = scene.closest_hit(&ray(origin, dir), range as f32)?;
    let (t, n) = exact(scene, hit.triangle, origin, dir)?;
    Some((origin + dir * t, n))
}
