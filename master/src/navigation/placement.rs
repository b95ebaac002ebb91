//! Where the room is in the scene: a rigid transform (rotation, then translation), in f64,
//! that every mode changes and the frame state sends as a matrix.

use glam::{DMat4, DQuat, DVec3};

/// Room → scene: `scene = rotation · room + translation`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    pub rotation: DQuat,
    pub translation: DVec3,
}

impl Placement {
    /// From a rigid matrix (the config's start transform).
    pub fn from_mat4(m: &DMat4) -> Placement {
        let (_, rotation, translation) = m.to_scale_rotation_translation();
        Placement {
            rotation: rotation.normalize(),
            translation,
        }
    }

    pub fn to_mat4(&self) -> DMat4 {
        DMat4::from_rotation_translation(self.rotation, self.translation)
    }

    /// A room point in the scene.
    pub fn point(&self, room: DVec3) -> DVec3 {
        self.rotation * room + self.translation
    }

    /// A room direction in the scene.
    pub fn dir(&self, room: DVec3) -> DVec3 {
        self.rotation * room
    }

    /// Moves the room by `v` (scene metres).
    pub fn shift(&mut self, v: DVec3) {
        self.translation += v;
    }

    /// Turns the room by `q` (scene frame) about the scene point `pivot`, which stays put.
    pub fn turn_about(&mut self, pivot: DVec3, q: DQuat) {
        self.rotation = (q * self.rotation).normalize();
        self.translation = pivot + q * (self.translation - pivot);
    }

    /// This placement followed, on the room side, by the rigid room motion `(q, t)`
    /// inverted: `scene = M · D⁻¹ · room`, where `D: room → room` is `p ↦ q·p + t`.
    pub fn then_inverse_of(&mut self, q: DQuat, t: DVec3) {
        // D⁻¹ p = q⁻¹ (p − t)
        let qi = q.inverse();
        self.translation -= self.rotation * (qi * t);
        self.rotation = (self.rotation * qi).normalize();
    }
}

/// The part of rotation `q` about +Y (its twist): no pitch, no roll.
pub fn yaw_part(q: DQuat) -> DQuat {
    let t = DQuat::from_xyzw(0.0, q.y, 0.0, q.w);
    let n = t.length();
    if n < 1e-12 { DQuat::IDENTITY } else { t / n }
}

/// `v` without its vertical part, as a unit vector (`None` when nearly vertical).
pub fn horizontal(v: DVec3) -> Option<DVec3> {
    let h = DVec3::new(v.x, 0.0, v.z);
    let n = h.length();
    (n > 1e-6).then(|| h / n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn turning_keeps_the_pivot_and_the_inverse_motion_undoes_a_room_motion() {
        let mut p = Placement {
            rotation: DQuat::from_rotation_y(0.3),
            translation: DVec3::new(1.0, 2.0, 3.0),
        };
        let pivot = p.point(DVec3::new(0.5, 1.7, -0.2));
        p.turn_about(pivot, DQuat::from_rotation_y(1.1));
        assert!((p.point(DVec3::new(0.5, 1.7, -0.2)) - pivot).length() < 1e-12);
        // After M·D⁻¹, the room point D·r shows the scene point that r showed before.
        let before = p;
        let (q, t) = (DQuat::from_rotation_x(0.4), DVec3::new(0.1, -0.2, 0.3));
        p.then_inverse_of(q, t);
        let r = DVec3::new(-0.3, 1.0, 0.7);
        assert!((p.point(q * r + t) - before.point(r)).length() < 1e-12);
        let y = yaw_part(DQuat::from_rotation_y(0.7) * DQuat::from_rotation_x(0.2));
        assert!((y.to_axis_angle().1 - 0.7).abs() < 1e-12);
    }
}
