//! Veiling glare (Ward Larson, Rushmeier & Piatko 1997, its veiling luminance; Radiance
//! `pcond4.c`): light scattered in the eye from bright sources lays a veil over what lies
//! near them, by the Holladay–Stiles (Moon & Spencer) formula
//!
//! ```text
//! L_v = K · Σ_i E_i / θ_i²,   K = 10 cd·m⁻²·lx⁻¹·deg²  (θ in degrees)
//! ```
//!
//! where `E_i` is source `i`'s illuminance at the eye on the plane across the line of
//! sight (`L_i · ω_i · cos θ_i` for a foveal sample of luminance `L_i` and solid angle
//! `ω_i`) and `θ_i` its angle from the line of sight. Samples within the fovea (closer than
//! half its diameter) do not veil. Over a uniform field filling the hemisphere this gives
//! `L_v = 0.087·L` ([`VEIL_OF_UNIFORM_FIELD`]): the eye's scatter takes that fraction of the
//! light from where it was aimed, so the world luminance becomes `(1 − 0.087)·L + L_v`
//! (`pcond` subtracts its 8% the same way), and a uniform field looks as it is.
//!
//! Everything here is linear in radiance, so the veil is computed in the scene's radiance
//! units (RGB: the veil has its sources' colour) and the luminous efficacy cancels.
//!
//! A CAVE's head sees every wall at once: each wall exports its bright foveal samples as
//! [`VeilSources`] (direction and `L·ω`, in the scene's frame) and adds the other walls'
//! to its own, so a sun patch on the floor veils the front wall.

use glam::Vec3;

use super::fovea::{FOVEA_DEG, Fovea};

/// Holladay's constant with θ in radians: 10 cd·m⁻²·lx⁻¹·deg² × (π/180)² deg²/rad².
pub const HOLLADAY_K: f32 = 10.0 * (std::f32::consts::PI / 180.0) * (std::f32::consts::PI / 180.0);
/// The veil over a uniform field of luminance `L` filling the hemisphere, as a fraction of
/// `L`: `K·2π·∫ cos θ sin θ / θ² dθ` from half a fovea (0.5°) to 90°.
pub const VEIL_OF_UNIFORM_FIELD: f32 = 0.087;
/// A foveal sample is exported as a glare source when its luminance is at least this many
/// times the mean of its wall's samples (`evalglare`'s default rule for sources).
pub const SOURCE_FACTOR: f32 = 5.0;
/// At most this many sources are exported per wall (the brightest in illuminance): a few
/// kilobytes per frame in the frame sync.
pub const MAX_SHARED: usize = 256;

/// One veiling source: the unit direction it lies in from the eye, and its radiance times
/// its solid angle (scene radiance units × sr, RGB) — its illuminance at the eye head-on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VeilSource {
    pub dir: Vec3,
    pub flux: Vec3,
}

/// The bright foveal samples a wall shares with the other walls (or imports from them).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VeilSources(pub Vec<VeilSource>);

impl VeilSources {
    pub fn none() -> VeilSources {
        VeilSources(Vec::new())
    }

    /// The sources of one wall to send to the others: its foveal samples (`means` per
    /// cell of `fovea`) whose luminance is at least [`SOURCE_FACTOR`] times the wall's mean,
    /// the [`MAX_SHARED`] brightest by illuminance.
    pub fn export(fovea: &Fovea, means: &[Vec3]) -> VeilSources {
        let lum = |c: Vec3| holocave_scene::luminance(c);
        let mean = means.iter().map(|&c| lum(c)).sum::<f32>() / means.len().max(1) as f32;
        let mut v: Vec<VeilSource> = means
            .iter()
            .zip(fovea.dirs.iter().zip(&fovea.omega))
            .filter(|(c, _)| mean > 0.0 && lum(**c) >= SOURCE_FACTOR * mean)
            .map(|(&c, (&dir, &omega))| VeilSource {
                dir,
                flux: c * omega,
            })
            .collect();
        v.sort_by(|a, b| lum(b.flux).total_cmp(&lum(a.flux)));
        v.truncate(MAX_SHARED);
        VeilSources(v)
    }

    /// The sources of several walls as one list (what a wall imports from the others).
    pub fn merged<'a>(walls: impl IntoIterator<Item = &'a VeilSources>) -> VeilSources {
        VeilSources(
            walls
                .into_iter()
                .flat_map(|w| w.0.iter().copied())
                .collect(),
        )
    }
}

/// The veil a source of `flux` in direction `src` lays on the line of sight `dir` (both
/// unit): `K · flux · cos θ / θ²`, nothing within half a fovea or behind.
pub fn veil_of(dir: Vec3, src: Vec3, flux: Vec3) -> Vec3 {
    let c = dir.dot(src);
    // θ from the chord: accurate at small angles, where acos is not.
    let theta = 2.0 * (0.5 * (dir - src).length()).min(1.0).asin();
    if c <= 0.0 || theta < 0.5 * FOVEA_DEG.to_radians() {
        return Vec3::ZERO;
    }
    flux * (HOLLADAY_K * c / (theta * theta))
}

/// The veil on each foveal sample of `fovea` from its own samples (`means`) and the
/// `imported` sources of the other walls.
pub fn veil(fovea: &Fovea, means: &[Vec3], imported: &VeilSources) -> Vec<Vec3> {
    let own = means.iter().zip(&fovea.omega).zip(&fovea.dirs);
    let sources: Vec<VeilSource> = own
        .map(|((&c, &omega), &dir)| VeilSource {
            dir,
            flux: c * omega,
        })
        .chain(imported.0.iter().copied())
        .collect();
    fovea
        .dirs
        .iter()
        .map(|&d| {
            sources
                .iter()
                .fold(Vec3::ZERO, |acc, s| acc + veil_of(d, s.dir, s.flux))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_kernel_over_a_uniform_hemisphere_is_the_stated_fraction() {
        // Sum the kernel over a fine grid of the hemisphere around the line of sight (+z)
        // in polar rings: the veil of unit luminance everywhere. The rings' midpoint rule
        // in log θ is exact to well under 1%.
        let n = 4000;
        let (a, b) = ((0.5f32).to_radians().ln(), std::f32::consts::FRAC_PI_2.ln());
        let mut v = 0.0f64;
        for k in 0..n {
            let u = a + (b - a) * (k as f32 + 0.5) / n as f32;
            let t = u.exp();
            let dt = t * (b - a) / n as f32;
            let omega = 2.0 * std::f32::consts::PI * t.sin() * dt;
            let src = Vec3::new(t.sin(), 0.0, t.cos());
            v += f64::from(veil_of(Vec3::Z, src, Vec3::splat(omega)).x);
        }
        assert!(
            (v as f32 - VEIL_OF_UNIFORM_FIELD).abs() < 0.005 * VEIL_OF_UNIFORM_FIELD,
            "a uniform field veils {v}, stated {VEIL_OF_UNIFORM_FIELD}"
        );
    }
}
