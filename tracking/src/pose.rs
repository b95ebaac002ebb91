//! Poses and timestamped samples: the one currency every tracker source produces.

use glam::{Quat, Vec3};

/// A rigid pose: position in metres and a unit quaternion `(x, y, z, w)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    pub position: Vec3,
    pub orientation: Quat,
}

impl Pose {
    /// The origin, unrotated.
    pub const IDENTITY: Pose = Pose {
        position: Vec3::ZERO,
        orientation: Quat::IDENTITY,
    };

    pub fn new(position: Vec3, orientation: Quat) -> Self {
        Pose {
            position,
            orientation,
        }
    }

    /// True when no component is NaN or infinite.
    pub fn is_finite(&self) -> bool {
        self.position.is_finite() && self.orientation.is_finite()
    }

    /// `self` followed by `other` expressed in `self`'s frame (`self ∘ other`).
    pub fn compose(&self, other: &Pose) -> Pose {
        Pose {
            position: self.position + self.orientation * other.position,
            orientation: (self.orientation * other.orientation).normalize(),
        }
    }
}

/// One tracker report: a pose at a time in nanoseconds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    pub t_ns: u64,
    pub pose: Pose,
}

impl Sample {
    pub fn new(t_ns: u64, pose: Pose) -> Self {
        Sample { t_ns, pose }
    }
}

/// Seconds between two nanosecond timestamps (`b - a`, negative when `b < a`).
pub fn seconds_between(a_ns: u64, b_ns: u64) -> f32 {
    ((b_ns as i128 - a_ns as i128) as f64 * 1e-9) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compose_applies_rotation_to_offset() {
        let head = Pose::new(
            Vec3::new(1.0, 2.0, 3.0),
            Quat::from_rotation_y(std::f32::consts::FRAC_PI_2),
        );
        let eyes = Pose::new(Vec3::new(1.0, 0.0, 0.0), Quat::IDENTITY);
        let p = head.compose(&eyes);
        assert!((p.position - Vec3::new(1.0, 2.0, 2.0)).length() < 1e-6);
    }

    #[test]
    fn seconds_between_is_signed() {
        assert_eq!(seconds_between(2_000_000_000, 1_000_000_000), -1.0);
        assert_eq!(seconds_between(0, 5_000_000), 0.005);
    }
}
