//! The Perez all-weather sky (Perez, Seals & Michalsky 1993, *All-weather model for sky
//! luminance distribution*, Solar Energy 50(3)), as Radiance's `gendaylit` makes it from
//! direct normal and diffuse horizontal irradiance, and `perezlum.cal` draws it.
//!
//! From the hour's DNI, DHI and the sun's zenith angle Z: the sky's clearness
//! ε = ((DHI + DNI)/DHI + 1.041 Z³)/(1 + 1.041 Z³) and brightness Δ = DHI · m / E₀ₙ
//! (m: Kasten's air mass, E₀ₙ: 1367 W/m² times the orbit's eccentricity factor), each held
//! to gendaylit's range (ε in [1, 12.009], Δ in [0.01, 0.6]); ε picks one of eight bins of
//! the paper's Table 1, whose rows give the coefficients a…e (in bins 2–4, Δ is taken as at
//! least 0.2, as gendaylit does). The relative radiance in a direction at zenith angle θ
//! and angle γ from the sun is `(1 + a e^{b / cos θ}) (1 + c e^{d γ} + e cos² γ)`
//! (cos θ held to at least 0.01, as `perezlum.cal` does), and never below zero: for some
//! rare ε and Δ the model is negative over part of the sky, which gendaylit passes on.
//!
//! **Normalisation.** The relative distribution is scaled so that the dome's irradiance on
//! a horizontal surface equals the DHI: gendaylit does the same with a sum over 145 sky
//! points; here the integral is a 180 × 720 midpoint rule (0.5° steps), whose error is far
//! below 0.1 %. Radiance is in W·m⁻²·sr⁻¹ of solar radiation (`gendaylit -O 1`), white;
//! luminance is 179 lm/W times it, as everywhere in holocave ([`crate::photometry`]).

use std::f64::consts::PI;

use glam::{DVec3, Vec3};
use thiserror::Error;

/// An hour the Perez sky cannot be made for.
#[derive(Debug, Error, PartialEq)]
pub enum PerezError {
    #[error("{name} must be finite and non-negative, got {value} W/m²")]
    Irradiance { name: &'static str, value: f64 },
    #[error("DNI {dni} W/m² is more than the sun gives outside the atmosphere ({limit:.0} W/m²)")]
    AboveExtraterrestrial { dni: f64, limit: f64 },
    #[error("day of year {0} is not in 1..=366")]
    Day(u32),
}

/// The Perez 1993 coefficients (Table 1): per ε bin, rows a…e of `[x1, x2, x3, x4]`, each
/// coefficient `x1 + x2 Z + Δ (x3 + x4 Z)` (bin 1's c and d have their own forms).
const TABLE: [[[f64; 4]; 5]; 8] = [
    [
        [1.3525, -0.2576, -0.2690, -1.4366],
        [-0.7670, 0.0007, 1.2734, -0.1233],
        [2.8000, 0.6004, 1.2375, 1.0000],
        [1.8734, 0.6297, 0.9738, 0.2809],
        [0.0356, -0.1246, -0.5718, 0.9938],
    ],
    [
        [-1.2219, -0.7730, 1.4148, 1.1016],
        [-0.2054, 0.0367, -3.9128, 0.9156],
        [6.9750, 0.1774, 6.4477, -0.1239],
        [-1.5798, -0.5081, -1.7812, 0.1080],
        [0.2624, 0.0672, -0.2190, -0.4285],
    ],
    [
        [-1.1000, -0.2515, 0.8952, 0.0156],
        [0.2782, -0.1812, -4.5000, 1.1766],
        [24.7219, -13.0812, -37.7000, 34.8438],
        [-5.0000, 1.5218, 3.9229, -2.6204],
        [-0.0156, 0.1597, 0.4199, -0.5562],
    ],
    [
        [-0.5484, -0.6654, -0.2672, 0.7117],
        [0.7234, -0.6219, -5.6812, 2.6297],
        [33.3389, -18.3000, -62.2500, 52.0781],
        [-3.5000, 0.0016, 1.1477, 0.1062],
        [0.4659, -0.3296, -0.0876, -0.0329],
    ],
    [
        [-0.6000, -0.3566, -2.5000, 2.3250],
        [0.2937, 0.0496, -5.6812, 1.8415],
        [21.0000, -4.7656, -21.5906, 7.2492],
        [-3.5000, -0.1554, 1.4062, 0.3988],
        [0.0032, 0.0766, -0.0656, -0.1294],
    ],
    [
        [-1.0156, -0.3670, 1.0078, 1.4051],
        [0.2875, -0.5328, -3.8500, 3.3750],
        [14.0000, -0.9999, -7.1406, 7.5469],
        [-3.4000, -0.1078, -1.0750, 1.5702],
        [-0.0672, 0.4016, 0.3017, -0.4844],
    ],
    [
        [-1.0000, 0.0211, 0.5025, -0.5119],
        [-0.3000, 0.1922, 0.7023, -1.6317],
        [19.0000, -5.0000, 1.2438, -1.9094],
        [-4.0000, 0.0250, 0.3844, 0.2656],
        [1.0468, -0.3788, -2.4517, 1.4656],
    ],
    [
        [-1.0500, 0.0289, 0.4260, 0.3590],
        [-0.3250, 0.1156, 0.7781, 0.0025],
        [31.0625, -14.5000, -46.1148, 55.3750],
        [-7.2312, 0.4050, 13.3500, 0.6234],
        [1.5000, -0.6426, 1.8564, 0.5636],
    ],
];

/// The upper bounds of the ε bins 1–7 (bin 8 is open above).
const BIN_BOUNDS: [f64; 7] = [1.065, 1.230, 1.500, 1.950, 2.800, 4.500, 6.200];
/// gendaylit's range for ε and Δ.
const EPSILON_RANGE: (f64, f64) = (1.0, 12.009);
const DELTA_RANGE: (f64, f64) = (0.01, 0.6);
/// The solar constant gendaylit uses, W/m².
pub const SOLAR_CONSTANT: f64 = 1367.0;

/// A Perez sky for one hour.
#[derive(Clone, Debug, PartialEq)]
pub struct PerezSky {
    /// Unit scene direction towards the sun.
    pub sun: Vec3,
    /// Sky clearness ε and brightness Δ, held to gendaylit's range.
    pub epsilon: f64,
    pub delta: f64,
    /// a, b, c, d, e.
    pub coefficients: [f64; 5],
    /// W·m⁻²·sr⁻¹ per unit of the relative distribution.
    pub normalization: f64,
    /// The hour's irradiance, W/m².
    pub dni: f64,
    pub dhi: f64,
}

/// The orbit's eccentricity factor (R₀/R)² on `day` of the year (Spencer 1971).
pub fn eccentricity(day: u32) -> f64 {
    let g = 2.0 * PI * (f64::from(day) - 1.0) / 365.0;
    1.00011
        + 0.034221 * g.cos()
        + 0.00128 * g.sin()
        + 0.000719 * (2.0 * g).cos()
        + 0.000077 * (2.0 * g).sin()
}

/// Kasten's (1966) relative air mass at solar zenith `z` (radians).
fn air_mass(z: f64) -> f64 {
    let deg = z.to_degrees();
    1.0 / (z.cos() + 0.15 * (93.885 - deg).powf(-1.253))
}

fn check(name: &'static str, value: f64) -> Result<f64, PerezError> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(PerezError::Irradiance { name, value })
    }
}

/// ε and Δ for the hour, held to gendaylit's range.
pub fn clearness_brightness(z: f64, dni: f64, dhi: f64, day: u32) -> (f64, f64) {
    let k = 1.041 * z.powi(3);
    let epsilon = ((dhi + dni) / dhi + k) / (1.0 + k);
    let delta = dhi * air_mass(z) / (SOLAR_CONSTANT * eccentricity(day));
    (
        epsilon.clamp(EPSILON_RANGE.0, EPSILON_RANGE.1),
        delta.clamp(DELTA_RANGE.0, DELTA_RANGE.1),
    )
}

/// The coefficients a…e for sun zenith `z` (radians), ε and Δ.
pub fn coefficients(z: f64, epsilon: f64, delta: f64) -> [f64; 5] {
    let bin = BIN_BOUNDS.iter().filter(|&&b| epsilon >= b).count();
    let delta = if epsilon > 1.065 && epsilon < 2.8 {
        delta.max(0.2)
    } else {
        delta
    };
    let x = &TABLE[bin];
    let mut c = [0.0; 5];
    for (ci, xi) in c.iter_mut().zip(x) {
        *ci = xi[0] + xi[1] * z + delta * (xi[2] + xi[3] * z);
    }
    if bin == 0 {
        c[2] = (delta * (x[2][0] + x[2][1] * z)).powf(x[2][2]).exp() - x[2][3];
        c[3] = -(delta * (x[3][0] + x[3][1] * z)).exp() + x[3][2] + delta * x[3][3];
    }
    c
}

/// The relative Perez radiance at `cos_zenith` (of the direction) and angle `gamma`
/// (radians) from the sun. The model goes negative for some rare ε and Δ (a < −1: a
/// gradation darker than nothing towards the zenith); no light is negative, so those
/// directions are dark, and the normalisation integrates what is drawn.
fn relative(c: &[f64; 5], cos_zenith: f64, gamma: f64) -> f64 {
    let cos_gamma = gamma.cos();
    let l = (1.0 + c[0] * (c[1] / cos_zenith.max(0.01)).exp())
        * (1.0 + c[2] * (c[3] * gamma).exp() + c[4] * cos_gamma * cos_gamma);
    l.max(0.0)
}

/// `∫ f(θ, γ) cos θ dω` over the upper hemisphere by the midpoint rule on an
/// `n × 4n` grid of zenith and azimuth angles about +Y.
fn horizontal_integral(sun: DVec3, n: usize, f: impl Fn(f64, f64) -> f64) -> f64 {
    let (dt, dp) = (0.5 * PI / n as f64, 2.0 * PI / (4 * n) as f64);
    let mut sum = 0.0;
    for i in 0..n {
        let (s, c) = ((i as f64 + 0.5) * dt).sin_cos();
        for j in 0..4 * n {
            let (sp, cp) = ((j as f64 + 0.5) * dp).sin_cos();
            let d = DVec3::new(s * cp, c, s * sp);
            sum += f(c, d.dot(sun).clamp(-1.0, 1.0).acos()) * c * s;
        }
    }
    sum * dt * dp
}

impl PerezSky {
    /// The sky of an hour with direct normal `dni` and diffuse horizontal `dhi`
    /// irradiance (W/m²), the sun towards `sun` (unit, scene coordinates, +Y up), on
    /// `day` of the year. `None` when there is no sky to draw: the sun at or below the
    /// horizon, or no diffuse light.
    pub fn new(sun: Vec3, dni: f64, dhi: f64, day: u32) -> Result<Option<PerezSky>, PerezError> {
        let (dni, dhi) = (check("DNI", dni)?, check("DHI", dhi)?);
        if !(1..=366).contains(&day) {
            return Err(PerezError::Day(day));
        }
        let limit = SOLAR_CONSTANT * eccentricity(day);
        if dni > limit {
            return Err(PerezError::AboveExtraterrestrial { dni, limit });
        }
        let sun = sun.as_dvec3().normalize();
        if sun.y <= 0.0 || dhi == 0.0 {
            return Ok(None);
        }
        let z = sun.y.clamp(-1.0, 1.0).acos();
        let (epsilon, delta) = clearness_brightness(z, dni, dhi, day);
        let c = coefficients(z, epsilon, delta);
        let integral = horizontal_integral(sun, 180, |cz, g| relative(&c, cz, g));
        Ok(Some(PerezSky {
            sun: sun.as_vec3(),
            epsilon,
            delta,
            coefficients: c,
            normalization: dhi / integral,
            dni,
            dhi,
        }))
    }

    /// Radiance, W·m⁻²·sr⁻¹, from the unit direction `dir` above the horizon.
    pub fn radiance(&self, dir: Vec3) -> f64 {
        let d = dir.as_dvec3();
        let gamma = d.dot(self.sun.as_dvec3()).clamp(-1.0, 1.0).acos();
        self.normalization * relative(&self.coefficients, d.y, gamma)
    }

    /// The dome's irradiance on a horizontal surface, W/m², by the midpoint rule on an
    /// `n × 4n` grid (the normalisation uses `n` = 180).
    pub fn horizontal_irradiance(&self, n: usize) -> f64 {
        let c = self.coefficients;
        self.normalization
            * horizontal_integral(self.sun.as_dvec3(), n, |cz, g| relative(&c, cz, g))
    }

    /// The radiance at the zenith.
    pub fn zenith_radiance(&self) -> f64 {
        self.radiance(Vec3::Y)
    }
}

#[cfg(test)]
mod tests;
