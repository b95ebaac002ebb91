//! Where a movable object stands: a rigid motion (rotation, then translation) from the
//! object's own frame to the world. Rigid, so distances along a ray are the same in both
//! frames and one BVH per object serves every placement.

use glam::{Mat4, Quat, Vec3};

/// A rigid placement: `world = rotation · local + translation`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Placement {
    pub translation: Vec3,
    /// A unit quaternion.
    pub rotation: Quat,
}

impl Placement {
    pub fn new(translation: Vec3, rotation: Quat) -> Self {
        Self {
            translation,
            rotation,
        }
    }

    /// The rigid part of an affine transform (its scale is dropped).
    pub fn rigid_part(m: &Mat4) -> Self {
        let (_, rotation, translation) = m.to_scale_rotation_translation();
        Self::new(translation, rotation.normalize())
    }

    pub fn to_world_point(&self, p: Vec3) -> Vec3 {
        self.rotation * p + self.translation
    }

    pub fn to_world_dir(&self, d: Vec3) -> Vec3 {
        self.rotation * d
    }

    pub fn to_local_point(&self, p: Vec3) -> Vec3 {
        self.rotation.inverse() * (p - self.translation)
    }

    pub fn to_local_dir(&self, d: Vec3) -> Vec3 {
        self.rotation.inverse() * d
    }

    /// `inner`, a placement in this one's frame, placed in the world (a thing held in a
    /// hand, the hand placed).
    pub fn then(&self, inner: &Placement) -> Placement {
        Placement::new(
            self.to_world_point(inner.translation),
            (self.rotation * inner.rotation).normalize(),
        )
    }

    /// `world`, a placement in the world, in this one's frame: the inverse of
    /// [`Placement::then`].
    pub fn relative(&self, world: &Placement) -> Placement {
        Placement::new(
            self.to_local_point(world.translation),
            (self.rotation.inverse() * world.rotation).normalize(),
        )
    }

    /// The placement a fraction `s` of the way from `self` to `to`: translation along the
    /// straight line, rotation along the shorter great arc (`s` = 0 gives `self`, 1 `to`).
    pub fn lerp(&self, to: &Placement, s: f32) -> Placement {
        let end = if self.rotation.dot(to.rotation) < 0.0 {
            -to.rotation
        } else {
            to.rotation
        };
        Placement::new(
            self.translation.lerp(to.translation, s),
            self.rotation.slerp(end, s).normalize(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn local_and_world_are_inverse() {
        let p = Placement::new(Vec3::new(1.0, -2.0, 3.0), Quat::from_rotation_y(0.7));
        let v = Vec3::new(0.3, 0.4, -0.5);
        assert!(p.to_local_point(p.to_world_point(v)).distance(v) < 1e-6);
        assert!(
            p.to_world_dir(Vec3::X)
                .distance(Vec3::new(0.7f32.cos(), 0.0, -0.7f32.sin()))
                < 1e-6
        );
        assert_eq!(Placement::default().to_world_point(v), v);
    }

    #[test]
    fn then_undoes_relative() {
        let hand = Placement::new(Vec3::new(1.0, 2.0, 0.5), Quat::from_rotation_y(0.9));
        let thing = Placement::new(Vec3::new(-0.4, 0.3, 2.0), Quat::from_rotation_x(0.4));
        let back = hand.then(&hand.relative(&thing));
        assert!(back.translation.distance(thing.translation) < 1e-5);
        assert!(back.rotation.dot(thing.rotation).abs() > 1.0 - 1e-6);
        let v = Vec3::new(0.3, -0.2, 0.1);
        assert!(
            hand.then(&thing)
                .to_world_point(v)
                .distance(hand.to_world_point(thing.to_world_point(v)))
                < 1e-5
        );
    }

    #[test]
    fn lerp_takes_the_short_arc() {
        let a = Placement::new(Vec3::ZERO, Quat::from_rotation_z(0.1));
        // The same rotation as z(−0.1), written with the opposite sign.
        let b = Placement::new(Vec3::new(2.0, 0.0, 0.0), -Quat::from_rotation_z(-0.1));
        let mid = a.lerp(&b, 0.5);
        assert!(mid.translation.distance(Vec3::X) < 1e-6);
        assert!(mid.rotation.angle_between(Quat::IDENTITY) < 1e-5, "{mid:?}");
        assert_eq!(a.lerp(&b, 0.0).translation, a.translation);
        assert!(a.lerp(&b, 1.0).rotation.angle_between(b.rotation) < 1e-5);
    }
}
