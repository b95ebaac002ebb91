//! Irradiance probes: the light arriving at one point from every direction, kept as
//! spherical harmonics of order 2 (nine coefficients per colour), from which the
//! irradiance on a surface of any orientation near the point follows at once.
//!
//! A moving object is not in the light field (nothing it does is baked), so its indirect
//! light comes from the light field's radiance arriving at a probe at its centre: the
//! holodeck paper's local objects are lit the same way, from the beams around them
//! (§2.4.6: the brightest beams as up to eight lights, the rest ambient). Here the bright,
//! sharp part — the sun, lamps and emitters — is computed exactly per pixel with shadow
//! rays (`pixel_direct`); what is left for the probe is the smooth remainder (light
//! reflected by the room and the sky), and irradiance from a smooth distribution is what
//! order-2 harmonics hold well: Ramamoorthi & Hanrahan (2001, "An efficient representation
//! for irradiance environment maps") show the clamped cosine kernel keeps over 99% of its
//! energy in orders 0–2, so the irradiance of any distant lighting is within a few percent
//! (on average 1–3%). A few lights would keep the brightest directions and lose the rest's
//! shape; nine numbers keep both for smooth light.

use glam::Vec3;

/// The nine real spherical harmonics of order 0–2 at unit direction `d` (the usual
/// normalised basis, `Y_00 = 1 / (2√π)`).
fn basis(d: Vec3) -> [f32; 9] {
    let (x, y, z) = (d.x, d.y, d.z);
    [
        0.282_095,
        0.488_603 * y,
        0.488_603 * z,
        0.488_603 * x,
        1.092_548 * x * y,
        1.092_548 * y * z,
        0.315_392 * (3.0 * z * z - 1.0),
        1.092_548 * x * z,
        0.546_274 * (x * x - y * y),
    ]
}

/// The clamped cosine's harmonic weights per band (`Â_0 = π`, `Â_1 = 2π/3`, `Â_2 = π/4`).
const COSINE: [f32; 9] = {
    let pi = std::f32::consts::PI;
    [
        pi,
        2.0 * pi / 3.0,
        2.0 * pi / 3.0,
        2.0 * pi / 3.0,
        pi / 4.0,
        pi / 4.0,
        pi / 4.0,
        pi / 4.0,
        pi / 4.0,
    ]
};

/// The `i`-th of `n` directions spread evenly over the sphere (a Fibonacci spiral: equal
/// areas, no clustering at the poles).
pub fn sphere_direction(i: u32, n: u32) -> Vec3 {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    let z = 1.0 - (2.0 * i as f32 + 1.0) / n as f32;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = golden * i as f32;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Incoming radiance at a point as order-2 harmonics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IrradianceProbe {
    pub position: Vec3,
    coeffs: [Vec3; 9],
}

impl IrradianceProbe {
    /// The probe at `position` from `n` directions spread evenly over the sphere:
    /// `incoming(d)` is the radiance arriving at the point from direction `d` (travelling
    /// along `−d`). Each direction stands for `4π / n` steradians.
    pub fn gather(position: Vec3, n: u32, incoming: impl Fn(Vec3) -> Vec3) -> Self {
        let n = n.max(1);
        let mut coeffs = [Vec3::ZERO; 9];
        for i in 0..n {
            let d = sphere_direction(i, n);
            let l = incoming(d);
            if !l.is_finite() {
                continue;
            }
            for (c, y) in coeffs.iter_mut().zip(basis(d)) {
                *c += l * y;
            }
        }
        let w = 4.0 * std::f32::consts::PI / n as f32;
        IrradianceProbe {
            position,
            coeffs: coeffs.map(|c| c * w),
        }
    }

    /// The irradiance on a surface with unit normal `normal` at the probe (never
    /// negative: the truncated series can dip below zero facing away from all light).
    pub fn irradiance(&self, normal: Vec3) -> Vec3 {
        let y = basis(normal);
        let mut e = Vec3::ZERO;
        for k in 0..9 {
            e += self.coeffs[k] * (COSINE[k] * y[k]);
        }
        e.max(Vec3::ZERO)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Radiance made of orders 0–2 alone is held exactly, so its irradiance is the
    /// analytic one: `L(d) = a + b d_z + c (3 d_z² − 1)` gives
    /// `E(n) = π a + (2π/3) b n_z + (π/4) c (3 n_z² − 1)`. The only error is the
    /// quadrature's over 4096 spiral points: well under 1e-3 of `π a`.
    #[test]
    fn low_order_radiance_gives_the_analytic_irradiance() {
        let (a, b, c) = (1.0f32, 0.6f32, 0.2f32);
        let probe = IrradianceProbe::gather(Vec3::ZERO, 4096, |d| {
            Vec3::splat(a + b * d.z + c * (3.0 * d.z * d.z - 1.0))
        });
        let pi = std::f32::consts::PI;
        for i in 0..50 {
            let n = sphere_direction(i, 50);
            let want = pi * a + 2.0 * pi / 3.0 * b * n.z + pi / 4.0 * c * (3.0 * n.z * n.z - 1.0);
            let got = probe.irradiance(n).x;
            assert!(
                (got - want).abs() < 1e-3 * pi * a,
                "normal {n}: {got} against {want}"
            );
        }
    }

    /// A uniform sky above the horizon (`L = 1` for `d_z > 0`): a surface facing up
    /// receives `π`, one on its side `π/2`, one facing down nothing. The step's
    /// band-2 part is zero and the clamped cosine has none in the odd bands above 1, so
    /// orders 0–2 give these three exactly; what is left is the quadrature's error on a
    /// step (the spiral's rows cross the horizon at spacing `2/n` in `z`), far below
    /// 1% of `π`.
    #[test]
    fn a_hemisphere_of_sky_lights_up_facing_surfaces() {
        let probe = IrradianceProbe::gather(Vec3::ZERO, 4096, |d| {
            Vec3::splat(if d.z > 0.0 { 1.0 } else { 0.0 })
        });
        let pi = std::f32::consts::PI;
        let up = probe.irradiance(Vec3::Z).x;
        let side = probe.irradiance(Vec3::X).x;
        let down = probe.irradiance(Vec3::NEG_Z).x;
        assert!((up - pi).abs() < 0.01 * pi, "up {up}");
        assert!((side - pi / 2.0).abs() < 0.01 * pi, "side {side}");
        assert!(down < 0.01 * pi, "down {down}");
    }
}
