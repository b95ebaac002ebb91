//! The 180° angular (equidistant) fisheye of a view — Radiance's `-vta -vh 180 -vv 180`,
//! the projection `evalglare` reads: a square image, first row up, whose centre is the
//! view direction and where a direction's distance from the centre is proportional to
//! its angle from the view direction (90° at the inscribed circle's edge).
//!
//! With the centre at `c = N/2` pixels, an image position `(px, py)` (pixels, `py` down)
//! has `u = (px − c)/c`, `v = (c − py)/c`, `r = √(u² + v²)` and sees the direction at
//! angle `θ = r·π/2` from the view direction, towards `u·right + v·up`.
//!
//! **Solid angles.** With `k = (π/2)/c` radians per pixel along a radius, the mapping's
//! Jacobian is `dΩ = k·sin(k ρ)/ρ dx dy` (`ρ`: the distance from the centre in pixels;
//! `k²` at the centre): a pixel's solid angle is that integral over its square, taken by
//! 4 × 4-point Gauss–Legendre quadrature (the integrand is analytic and varies on the
//! scale of the whole image, so the rule's error is far below f64 rounding for any image
//! of more than a few pixels). A pixel whose centre is outside the 180° circle is not
//! part of the view (solid angle 0), as in `evalglare` (a pixel counts when its centre's
//! direction is in front of the eye).

use glam::{DVec3, Vec3};

use crate::error::GlareError;

/// A 180° equidistant fisheye view of `size × size` pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct Fisheye {
    pub size: u32,
    pub eye: DVec3,
    /// Unit view direction (the image's centre).
    pub look: DVec3,
    /// Unit up, perpendicular to `look` (the image's upward direction).
    pub up: DVec3,
    /// Unit right: `look × up` (Radiance's horizontal view vector).
    pub right: DVec3,
}

/// Nodes and weights of 4-point Gauss–Legendre quadrature on [−1, 1].
const GAUSS4: [(f64, f64); 4] = [
    (-0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
    (-0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
    (0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
];

impl Fisheye {
    /// The fisheye of an eye looking along `look` with `up` as the image's up (made
    /// perpendicular to `look`). Errors: no pixels, or vectors that give no frame.
    pub fn new(size: u32, eye: Vec3, look: Vec3, up: Vec3) -> Result<Self, GlareError> {
        if size == 0 {
            return Err(GlareError::EmptyImage { size });
        }
        let (eye, look, up) = (eye.as_dvec3(), look.as_dvec3(), up.as_dvec3());
        if !eye.is_finite() {
            return Err(GlareError::BadView(format!("the eye {eye} is not finite")));
        }
        if !look.is_finite() || look.length() < 1e-9 {
            return Err(GlareError::BadView(format!(
                "the look direction {look} is not a direction"
            )));
        }
        let look = look.normalize();
        if !up.is_finite() || up.length() < 1e-9 {
            return Err(GlareError::BadView(format!(
                "the up direction {up} is not a direction"
            )));
        }
        let up = up.normalize();
        let perp = up - look * look.dot(up);
        // Up within about 0.06° of the look direction gives no usable image frame.
        if perp.length() < 1e-3 {
            return Err(GlareError::BadView(format!(
                "up {up} is along the look direction {look}: give another --up"
            )));
        }
        let up = perp.normalize();
        let right = look.cross(up);
        Ok(Fisheye {
            size,
            eye,
            look,
            up,
            right,
        })
    }

    /// The image's centre, pixels from the top-left corner along each axis.
    fn centre(&self) -> f64 {
        f64::from(self.size) / 2.0
    }

    /// Radians of view angle per pixel along a radius (`k`).
    pub fn radians_per_pixel(&self) -> f64 {
        std::f64::consts::FRAC_PI_2 / self.centre()
    }

    /// The direction seen at image position `(px, py)` (pixels from the top-left corner,
    /// `py` down), or `None` outside the 180° circle.
    pub fn direction(&self, px: f64, py: f64) -> Option<DVec3> {
        let c = self.centre();
        let (u, v) = ((px - c) / c, (c - py) / c);
        let r = u.hypot(v);
        if r > 1.0 {
            return None;
        }
        if r == 0.0 {
            return Some(self.look);
        }
        let theta = r * std::f64::consts::FRAC_PI_2;
        let side = (self.right * u + self.up * v) / r;
        Some((self.look * theta.cos() + side * theta.sin()).normalize())
    }

    /// The direction through the centre of pixel `(x, y)`, or `None` when the centre is
    /// outside the 180° circle (the pixel is not part of the view).
    pub fn pixel_direction(&self, x: u32, y: u32) -> Option<DVec3> {
        self.direction(f64::from(x) + 0.5, f64::from(y) + 0.5)
    }

    /// The image position where direction `d` is seen (the inverse of
    /// [`Fisheye::direction`]), or `None` for a direction behind the eye or not finite.
    pub fn position(&self, d: DVec3) -> Option<(f64, f64)> {
        let d = d.try_normalize()?;
        let cos = d.dot(self.look).clamp(-1.0, 1.0);
        if cos < 0.0 {
            return None;
        }
        let theta = cos.acos();
        let (a, b) = (d.dot(self.right), d.dot(self.up));
        let s = a.hypot(b);
        let c = self.centre();
        if s == 0.0 {
            return Some((c, c));
        }
        let r = theta / std::f64::consts::FRAC_PI_2;
        Some((c + c * r * a / s, c - c * r * b / s))
    }

    /// The solid angle, steradians, of pixel `(x, y)`: the mapping's Jacobian integrated
    /// over the pixel's square; 0 for a pixel whose centre is outside the 180° circle.
    pub fn solid_angle(&self, x: u32, y: u32) -> f64 {
        if self.pixel_direction(x, y).is_none() {
            return 0.0;
        }
        let c = self.centre();
        let k = self.radians_per_pixel();
        let (x0, y0) = (f64::from(x) + 0.5 - c, f64::from(y) + 0.5 - c);
        let mut sum = 0.0;
        for (sx, wx) in GAUSS4 {
            for (sy, wy) in GAUSS4 {
                let rho = (x0 + 0.5 * sx).hypot(y0 + 0.5 * sy);
                let kr = k * rho;
                // k·sin(kρ)/ρ = k²·sinc(kρ); the series near 0 avoids 0/0.
                let sinc = if kr < 1e-4 {
                    1.0 - kr * kr / 6.0
                } else {
                    kr.sin() / kr
                };
                sum += wx * wy * k * k * sinc;
            }
        }
        // The square is [−½, ½]² around the centre: the rule on [−1, 1]² scaled by ¼.
        sum * 0.25
    }

    /// Every pixel's solid angle, rows from the top.
    pub fn solid_angles(&self) -> Vec<f64> {
        let n = self.size;
        (0..n * n).map(|i| self.solid_angle(i % n, i / n)).collect()
    }

    /// Every pixel's centre direction (`None` outside the circle), rows from the top.
    pub fn directions(&self) -> Vec<Option<DVec3>> {
        let n = self.size;
        (0..n * n)
            .map(|i| self.pixel_direction(i % n, i / n))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn view(size: u32) -> Fisheye {
        Fisheye::new(size, Vec3::ZERO, Vec3::new(0.3, -0.2, -1.0), Vec3::Y).unwrap()
    }

    /// The first row is up and the first column left; the circle's edge is 90° from the
    /// view direction.
    #[test]
    fn orientation_and_edge() {
        let f = view(64);
        let c = 32.0;
        assert!((f.direction(c, c).unwrap() - f.look).length() < 1e-12);
        let top = f.direction(c, 0.0).unwrap();
        assert!((top - f.up).length() < 1e-12, "{top}");
        let left = f.direction(0.0, c).unwrap();
        assert!((left + f.right).length() < 1e-12, "{left}");
        assert!(f.direction(0.0, 0.0).is_none());
        // Looking along −Z with +Y up, right is +X (Radiance's look × up).
        let g = Fisheye::new(8, Vec3::ZERO, -Vec3::Z, Vec3::Y).unwrap();
        assert!((g.right - DVec3::X).length() < 1e-12);
    }

    /// `position` inverts `direction` everywhere inside the circle (to f64 rounding of
    /// a few operations on numbers of the image's size: 1e-9 px).
    #[test]
    fn position_inverts_direction() {
        let f = view(50);
        for y in 0..50 {
            for x in 0..50 {
                let (px, py) = (f64::from(x) + 0.3, f64::from(y) + 0.7);
                let Some(d) = f.direction(px, py) else {
                    continue;
                };
                let (qx, qy) = f.position(d).unwrap();
                assert!(
                    (qx - px).abs() < 1e-9 && (qy - py).abs() < 1e-9,
                    "{px},{py}"
                );
            }
        }
        assert!(f.position(-f.look).is_none());
    }

    /// A centred square of half-side `a` pixels (here 2 × 2 pixels) has the solid angle
    /// `∮ (1 − cos kρ) dφ` around its edge (Green's theorem on `k sin(kρ) dρ dφ`),
    /// integrated independently here by Simpson's rule over φ in 20 000 steps (error
    /// far below 1e-12 of the result for this smooth periodic integrand).
    #[test]
    fn solid_angle_is_the_mappings_integral() {
        let f = view(16);
        let k = f.radians_per_pixel();
        let a = 1.0;
        let n = 20_000;
        let g = |phi: f64| {
            let rho = a / phi.cos().abs().max(phi.sin().abs());
            1.0 - (k * rho).cos()
        };
        let h = std::f64::consts::TAU / f64::from(n);
        let mut s = g(0.0) + g(std::f64::consts::TAU);
        for i in 1..n {
            s += g(f64::from(i) * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        let exact = s * h / 3.0;
        let quad: f64 = [(7, 7), (8, 7), (7, 8), (8, 8)]
            .iter()
            .map(|&(x, y)| f.solid_angle(x, y))
            .sum();
        assert!(
            ((quad - exact) / exact).abs() < 1e-9,
            "{quad} against {exact}"
        );
    }

    /// The pixels in the circle cover the hemisphere, 2π sr, but for the pixels that the
    /// circle's edge crosses: those lie within `√2/2` px of radius `c`, a band of area
    /// `2πc·√2` px² where the Jacobian is about `k/c`, so the total is within
    /// `2√2·π·k` of 2π (the pixels in and out of the circle partly cancel).
    #[test]
    fn pixels_cover_the_hemisphere() {
        for n in [32, 63, 128] {
            let f = view(n);
            let total: f64 = f.solid_angles().iter().sum();
            let bound = 2.0 * 2f64.sqrt() * std::f64::consts::PI * f.radians_per_pixel();
            let err = (total - std::f64::consts::TAU).abs();
            assert!(err < bound, "{n}: {total}, bound {bound}");
        }
    }

    #[test]
    fn bad_views_are_refused() {
        assert!(matches!(
            Fisheye::new(0, Vec3::ZERO, Vec3::Z, Vec3::Y),
            Err(GlareError::EmptyImage { .. })
        ));
        assert!(Fisheye::new(8, Vec3::ZERO, Vec3::ZERO, Vec3::Y).is_err());
        assert!(Fisheye::new(8, Vec3::ZERO, Vec3::Y, Vec3::Y * 2.0).is_err());
        assert!(Fisheye::new(8, Vec3::ZERO, Vec3::new(f32::NAN, 0.0, 1.0), Vec3::Y).is_err());
    }
}
