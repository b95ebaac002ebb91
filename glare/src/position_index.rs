//! The position index `P` of a glare source: how much less a source glares the farther it
//! is from the line of sight, as `evalglare` computes it (its default, `get_posindex`
//! with Guth's model).
//!
//! With `σ` the angle between the line of sight and the source, `τ` the angle between
//! the view's up and the source's direction projected on the plane perpendicular to the
//! line of sight (both in degrees), above the line of sight (Guth's equation as the IES
//! Lighting Handbook gives it):
//!
//! ```text
//! P = exp( (35.2 − 0.31889 τ − 1.22 e^(−2τ/9)) · 10⁻³ · σ
//!        + (21 + 0.26667 τ − 0.002963 τ²) · 10⁻⁵ · σ² )
//! ```
//!
//! Below the line of sight (the source's elevation `φ = asin(up · d)` negative), Iwata's
//! model: with `θ = asin(right · d)`, `R = √(tan²φ + tan²θ)` capped at 3,
//! `P = 1 + 0.8 R` for `R ≤ 0.6`, else `1 + 1.2 R`. `P` is capped at 16 in both cases.
//! `P = 1` on the line of sight.

use glam::DVec3;

/// The largest position index (`evalglare`'s cap).
pub const MAX_POSITION_INDEX: f64 = 16.0;

/// Guth's position index for a source at `sigma` degrees from the line of sight and
/// `tau` degrees from the vertical (above the line of sight).
pub fn guth(sigma: f64, tau: f64) -> f64 {
    let a = (35.2 - 0.31889 * tau - 1.22 * (-2.0 * tau / 9.0).exp()) / 1000.0;
    let b = (21.0 + 0.26667 * tau - 0.002963 * tau * tau) / 100_000.0;
    (a * sigma + b * sigma * sigma)
        .exp()
        .min(MAX_POSITION_INDEX)
}

/// Iwata's position index below the line of sight: `phi` the source's (negative)
/// elevation and `theta` its horizontal angle, radians.
pub fn iwata(phi: f64, theta: f64) -> f64 {
    let r = phi.tan().hypot(theta.tan());
    let fact = if r > 0.6 { 1.2 } else { 0.8 };
    (1.0 + fact * r.min(3.0)).min(MAX_POSITION_INDEX)
}

/// The position index of a source in unit direction `d` for a viewer looking along
/// `look` with `up` and `right` (unit, perpendicular; `right = look × up`).
pub fn position_index(d: DVec3, look: DVec3, up: DVec3, right: DVec3) -> f64 {
    let phi = up.dot(d).clamp(-1.0, 1.0).asin();
    if phi < 0.0 {
        let theta = right.dot(d).clamp(-1.0, 1.0).asin();
        return iwata(phi, theta);
    }
    let sigma = look.dot(d).clamp(-1.0, 1.0).acos().to_degrees();
    // The direction projected on the plane perpendicular to the line of sight; on the
    // line of sight itself σ = 0 and τ does not matter.
    let side = d - look * look.dot(d);
    let tau = match side.try_normalize() {
        Some(s) => up.dot(s).clamp(-1.0, 1.0).acos().to_degrees(),
        None => 0.0,
    };
    guth(sigma, tau)
}

#[cfg(test)]
mod tests {
    use super::*;

    const LOOK: DVec3 = DVec3::NEG_Z;
    const UP: DVec3 = DVec3::Y;
    const RIGHT: DVec3 = DVec3::X;

    fn at(elevation_deg: f64, azimuth_deg: f64) -> DVec3 {
        let (e, a) = (elevation_deg.to_radians(), azimuth_deg.to_radians());
        DVec3::new(e.cos() * a.sin(), e.sin(), -e.cos() * a.cos())
    }

    /// On the line of sight `P = 1` (σ = 0 makes Guth's exponent 0).
    #[test]
    fn one_on_the_line_of_sight() {
        assert_eq!(position_index(LOOK, LOOK, UP, RIGHT), 1.0);
        assert_eq!(guth(0.0, 37.0), 1.0);
    }

    /// Values worked by hand from the equations (to 5 digits, well inside the 1e-4
    /// tolerance):
    /// - straight above at σ = 30° (τ = 0): exponent `(35.2 − 1.22)·0.03 + 21·0.009`
    ///   `= 1.0194 + 0.189 = 1.2084`, P = e^1.2084 = 3.3481;
    /// - to the side at σ = 30° (τ = 90°): `35.2 − 28.7001 − 1.22 e^−20 = 6.49990`,
    ///   `21 + 24.0003 − 24.0003 = 21.0000` (0.002963·8100 = 24.0003), exponent
    ///   `0.194997 + 0.189 = 0.383997`, P = 1.46814;
    /// - 30° straight below (Iwata): R = tan 30° = 0.57735 ≤ 0.6, P = 1 + 0.8 R = 1.46188;
    /// - 60° straight below: R = tan 60° = 1.73205, P = 1 + 1.2 R = 3.07846.
    #[test]
    fn known_values() {
        let close = |a: f64, b: f64| (a - b).abs() < 1e-4 * b;
        let above = position_index(at(30.0, 0.0), LOOK, UP, RIGHT);
        assert!(close(above, 3.3481), "{above}");
        let side = position_index(at(0.0, 30.0), LOOK, UP, RIGHT);
        assert!(close(side, 1.46814), "{side}");
        let below = position_index(at(-30.0, 0.0), LOOK, UP, RIGHT);
        assert!(close(below, 1.46188), "{below}");
        let far_below = position_index(at(-60.0, 0.0), LOOK, UP, RIGHT);
        assert!(close(far_below, 3.07846), "{far_below}");
    }

    /// Far from the line of sight P reaches its cap of 16, and it grows with σ.
    #[test]
    fn grows_away_from_the_line_of_sight_to_its_cap() {
        let mut last = 0.0;
        for s in 0..=90 {
            let p = position_index(at(f64::from(s), 0.0), LOOK, UP, RIGHT);
            assert!(p >= last && p <= MAX_POSITION_INDEX, "{s}: {p}");
            last = p;
        }
        assert_eq!(last, MAX_POSITION_INDEX);
    }
}
