//! The sky dome cut into Tregenza's 145 patches (Radiance's `gendaymtx` at `-m 1`, the
//! Reinhart subdivision's first level) and one more for the ground: the sky's basis for
//! daylight coefficients. Seven bands of 12° of altitude hold 30, 30, 24, 24, 18, 12 and 6
//! patches; above 84° one cap. Azimuth counts in scene coordinates from
//! +X towards +Z (the order only has to agree with itself); up is +Y, as the sky's.

use std::f32::consts::{FRAC_PI_2, TAU};

use glam::Vec3;
use holocave_scene::daylight::Sky;

/// Patches per band, from the horizon up.
const BANDS: [usize; 8] = [30, 30, 24, 24, 18, 12, 6, 1];
/// The width of a band, radians (12°).
const BAND: f32 = FRAC_PI_2 * 12.0 / 90.0;
/// The sky's patches.
pub const SKY_PATCHES: usize = 145;
/// The ground's patch (every direction below the horizon).
pub const GROUND: usize = SKY_PATCHES;
/// Sky and ground.
pub const PATCHES: usize = SKY_PATCHES + 1;
/// Points per patch along each axis where an hour's sky is averaged over a patch.
const MEAN_GRID: usize = 8;

/// The first patch of each band.
fn band_start(band: usize) -> usize {
    BANDS[..band].iter().sum()
}

/// A patch's band, its place in the band, and the band's count.
fn locate(patch: usize) -> (usize, usize, usize) {
    let mut start = 0;
    for (band, &n) in BANDS.iter().enumerate() {
        if patch < start + n {
            return (band, patch - start, n);
        }
        start += n;
    }
    unreachable!("patch {patch} is past the sky's {SKY_PATCHES}")
}

/// A direction's azimuth in [0, 2π).
fn azimuth(dir: Vec3) -> f32 {
    let a = dir.z.atan2(dir.x);
    if a < 0.0 { a + TAU } else { a }
}

/// The patch a unit direction falls in ([`GROUND`] below the horizon).
pub fn patch_of(dir: Vec3) -> usize {
    if dir.y < 0.0 {
        return GROUND;
    }
    let altitude = dir.y.clamp(0.0, 1.0).asin();
    let band = ((altitude / BAND) as usize).min(BANDS.len() - 1);
    let n = BANDS[band];
    let j = ((azimuth(dir) / TAU * n as f32) as usize).min(n - 1);
    band_start(band) + j
}

/// The direction at `(a, b)` ∈ [0, 1]² of sky patch `patch`: `a` along its sine of
/// altitude, `b` along its azimuth (so that a uniform `(a, b)` is uniform in solid angle).
fn point_in(patch: usize, a: f32, b: f32) -> Vec3 {
    let (band, j, n) = locate(patch);
    let (s0, s1) = (
        (band as f32 * BAND).sin(),
        ((band + 1) as f32 * BAND).min(FRAC_PI_2).sin(),
    );
    let y = s0 + (s1 - s0) * a;
    let phi = (j as f32 + b) / n as f32 * TAU;
    let r = (1.0 - y * y).max(0.0).sqrt();
    Vec3::new(r * phi.cos(), y, r * phi.sin())
}

/// The centre of sky patch `patch` (the zenith for the cap): where a sun in the patch is
/// put for its light after the first bounce (at most a half diagonal, about 8.5°, away).
pub fn centre(patch: usize) -> Vec3 {
    if patch == SKY_PATCHES - 1 {
        return Vec3::Y;
    }
    point_in(patch, 0.5, 0.5).normalize()
}

/// An hour's sky as the basis sees it: each patch's mean luminance (the sky's radiance is
/// grey, `Sky`'s luminance), then the ground's.
pub fn mean_luminances(sky: &Sky) -> [f32; PATCHES] {
    let mut out = [0.0; PATCHES];
    for (p, l) in out.iter_mut().enumerate().take(SKY_PATCHES) {
        let mut sum = 0.0;
        for i in 0..MEAN_GRID {
            for k in 0..MEAN_GRID {
                let (a, b) = (
                    (i as f32 + 0.5) / MEAN_GRID as f32,
                    (k as f32 + 0.5) / MEAN_GRID as f32,
                );
                sum += holocave_scene::color::luminance(sky.radiance(point_in(p, a, b)));
            }
        }
        *l = sum / (MEAN_GRID * MEAN_GRID) as f32;
    }
    out[GROUND] = holocave_scene::color::luminance(sky.ground);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_point_of_a_patch_falls_in_it_and_the_patches_tile_the_dome() {
        let mut solid_angle = 0.0f64;
        for p in 0..SKY_PATCHES {
            for (a, b) in [(0.01, 0.01), (0.5, 0.5), (0.99, 0.99), (0.01, 0.99)] {
                assert_eq!(patch_of(point_in(p, a, b)), p, "patch {p} at ({a}, {b})");
            }
            assert_eq!(patch_of(centre(p)), p);
            let (band, _, n) = locate(p);
            let top = ((band + 1) as f64 * 12f64.to_radians()).min(std::f64::consts::FRAC_PI_2);
            solid_angle += std::f64::consts::TAU
                * (top.sin() - (band as f64 * 12f64.to_radians()).sin())
                / n as f64;
        }
        assert!(
            (solid_angle - std::f64::consts::TAU).abs() < 1e-9,
            "{solid_angle}"
        );
        assert_eq!(patch_of(Vec3::new(0.3, -0.1, 0.2).normalize()), GROUND);
        assert_eq!(patch_of(Vec3::Y), SKY_PATCHES - 1);
    }
}
