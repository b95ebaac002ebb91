//! Synthetic head motions for tests and demos: a head standing still, walking, turning,
//! nodding, and a fast shake. Each is a smooth closed-form function of time, so tests
//! know the true pose at any instant.

use std::f32::consts::TAU;
use std::fmt;
use std::str::FromStr;

use glam::{Quat, Vec3};

use crate::pose::{Pose, Sample};

/// Eye height of the synthetic user, metres above the floor.
pub const HEAD_HEIGHT: f32 = 1.7;

/// The motions on offer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Motion {
    /// Standing at the centre, looking at the front wall.
    Still,
    /// Walking left and right across the room (±1 m, 8 s period) with head bob.
    Walk,
    /// Turning the head ±90° about +Y every 4 s.
    Turn,
    /// Nodding ±20° about +X at 1 Hz.
    Nod,
    /// A fast head shake: ±30° about +Y at 3 Hz (peak ≈ 565°/s).
    Shake,
}

impl Motion {
    pub const ALL: [Motion; 5] = [
        Motion::Still,
        Motion::Walk,
        Motion::Turn,
        Motion::Nod,
        Motion::Shake,
    ];

    /// The true pose `t` seconds after the start.
    pub fn pose_at(self, t: f64) -> Pose {
        let base = Vec3::new(0.0, HEAD_HEIGHT, 0.0);
        let phase = |period: f64| ((t / period).fract() as f32) * TAU;
        match self {
            Motion::Still => Pose::new(base, Quat::IDENTITY),
            Motion::Walk => {
                let x = phase(8.0).sin();
                let bob = 0.02 * phase(0.5).sin();
                // Facing the way of travel a little.
                let yaw = -0.3 * phase(8.0).cos();
                Pose::new(base + Vec3::new(x, bob, 0.0), Quat::from_rotation_y(yaw))
            }
            Motion::Turn => Pose::new(
                base,
                Quat::from_rotation_y(90f32.to_radians() * phase(4.0).sin()),
            ),
            Motion::Nod => Pose::new(
                base,
                Quat::from_rotation_x(20f32.to_radians() * phase(1.0).sin()),
            ),
            Motion::Shake => Pose::new(
                base,
                Quat::from_rotation_y(30f32.to_radians() * phase(1.0 / 3.0).sin()),
            ),
        }
    }

    /// `seconds` of samples at `rate_hz`, starting at t = 0.
    pub fn samples(self, rate_hz: f64, seconds: f64) -> Vec<Sample> {
        let n = (seconds * rate_hz).round() as u64;
        (0..=n).map(|i| self.sample(i, rate_hz)).collect()
    }

    /// The `i`-th sample at `rate_hz`.
    pub fn sample(self, i: u64, rate_hz: f64) -> Sample {
        let t_ns = (i as f64 * 1e9 / rate_hz).round() as u64;
        Sample::new(t_ns, self.pose_at(t_ns as f64 * 1e-9))
    }
}

impl FromStr for Motion {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Motion::ALL
            .into_iter()
            .find(|m| m.to_string() == s)
            .ok_or_else(|| {
                format!("unknown synthetic motion `{s}` (expected still, walk, turn, nod or shake)")
            })
    }
}

impl fmt::Display for Motion {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Motion::Still => "still",
            Motion::Walk => "walk",
            Motion::Turn => "turn",
            Motion::Nod => "nod",
            Motion::Shake => "shake",
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rotation::angle_between;

    #[test]
    fn motions_have_the_documented_extent_and_are_unit() {
        for m in Motion::ALL {
            assert_eq!(m.to_string().parse::<Motion>(), Ok(m));
            let s = m.samples(120.0, 8.0);
            assert_eq!(s.len(), 961);
            assert!(
                s.iter()
                    .all(|s| (s.pose.orientation.length() - 1.0).abs() < 1e-6)
            );
            let max_angle = s
                .iter()
                .map(|s| angle_between(Quat::IDENTITY, s.pose.orientation))
                .fold(0.0, f32::max);
            let max_x = s
                .iter()
                .map(|s| s.pose.position.x.abs())
                .fold(0.0, f32::max);
            let expected_angle = match m {
                Motion::Still => 0.0,
                Motion::Walk => 0.3,
                Motion::Turn => 90f32.to_radians(),
                Motion::Nod => 20f32.to_radians(),
                Motion::Shake => 30f32.to_radians(),
            };
            assert!(
                (max_angle - expected_angle).abs() < 0.01,
                "{m}: {max_angle}"
            );
            assert!(
                (max_x - if m == Motion::Walk { 1.0 } else { 0.0 }).abs() < 1e-3,
                "{m}: {max_x}"
            );
        }
        assert!("jog".parse::<Motion>().unwrap_err().contains("shake"));
    }
}
