//! Quaternion calculus that stays accurate for the tiny per-sample rotations of head
//! tracking: rotation vectors (log/exp), the angle between two rotations, and slerp that
//! may extrapolate past its end point (which prediction needs).

use glam::{Quat, Vec3};

/// The rotation vector (axis × angle, radians) of a unit quaternion, taking the shorter way.
/// Uses `atan2`, which keeps full precision for angles near zero where `acos(w)` does not.
pub fn log(q: Quat) -> Vec3 {
    let q = if q.w < 0.0 { -q } else { q };
    let v = Vec3::new(q.x, q.y, q.z);
    let s = v.length();
    if s < 1e-12 {
        // sin(θ/2) ≈ θ/2, so the rotation vector is 2v.
        return 2.0 * v;
    }
    v * (2.0 * s.atan2(q.w) / s)
}

/// The unit quaternion of a rotation vector (inverse of [`log`]).
pub fn exp(v: Vec3) -> Quat {
    let angle = v.length();
    if angle < 1e-12 {
        return Quat::from_xyzw(0.5 * v.x, 0.5 * v.y, 0.5 * v.z, 1.0).normalize();
    }
    let (s, c) = (0.5 * angle).sin_cos();
    let a = v * (s / angle);
    Quat::from_xyzw(a.x, a.y, a.z, c)
}

/// The angle in radians between two rotations (0..π), independent of the sign of either.
pub fn angle_between(a: Quat, b: Quat) -> f32 {
    let d = a.conjugate() * b;
    2.0 * Vec3::new(d.x, d.y, d.z).length().atan2(d.w.abs())
}

/// `a · (a⁻¹ b)^t` along the shorter arc; `t` outside 0..1 extrapolates.
pub fn slerp(a: Quat, b: Quat, t: f32) -> Quat {
    (a * exp(log(a.conjugate() * b) * t)).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_exp_round_trip_small_and_large() {
        for angle in [1e-9_f32, 1e-4, 0.01, 1.0, 3.0] {
            let v = Vec3::new(0.3, -0.8, 0.52).normalize() * angle;
            let back = log(exp(v));
            assert!(
                (back - v).length() <= 1e-6 * angle.max(1.0),
                "{angle}: {back} vs {v}"
            );
        }
    }

    #[test]
    fn angle_ignores_sign() {
        let a = Quat::from_rotation_x(0.3);
        let b = Quat::from_rotation_x(0.5);
        assert!((angle_between(a, -b) - 0.2).abs() < 1e-6);
        assert!(angle_between(a, -a) < 1e-6);
    }

    #[test]
    fn slerp_extrapolates_at_constant_rate() {
        let a = Quat::from_rotation_y(0.1);
        let b = Quat::from_rotation_y(0.2);
        let c = slerp(a, -b, 3.0);
        assert!(angle_between(c, Quat::from_rotation_y(0.4)) < 1e-6);
        assert!(angle_between(slerp(a, b, 0.5), Quat::from_rotation_y(0.15)) < 1e-6);
    }
}
