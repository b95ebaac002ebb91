//! How a diffuse element takes light in and sends it out over directions: by its
//! material's directional albedo ([`crate::surface::albedo_towards`]) over its mean
//! ([`crate::surface::diffuse_albedo`]), the ratio `a(θ)` [`Exitance::towards`] gives.
//! The element's BSDF is taken as `f(ωo, ωi) = ρ a(θo) a(θi) / π`: separable, reciprocal,
//! and under even light the directional albedo `ρ a(θo)` exactly. So the light arriving
//! along a line or from a light sample counts `a(θi)` times its irradiance (what the
//! element keeps as its irradiance `E`), and the element sends along a line `B a(θo)`
//! with `B = ρ/π · E`; the view draws it with `ρ a(θo) E / π`, its albedo towards the eye.
//!
//! A rough dielectric's Lambertian base is dimmed towards grazing exits by the Fresnel
//! transmission out, `1 − F(θo)`: the breakfast room's white walls (GGX α 0.94 over a
//! Lambertian base) send a third of their mean towards a direction 87° off their normal,
//! and half at 84°. Two walls meeting in a corner see each other at just those angles
//! near the corner; sent evenly, their exchange there was twice the path tracer's and the
//! corner a quarter too bright. By reciprocity the same paint keeps less of the light
//! arriving at grazing angles and up to 4 % more of light arriving near its normal (the
//! sun patch across the room): taken evenly, the breakfast room's walls were 1.5 %
//! darker than the path tracer's. Each profile is scaled so that its cosine-weighted mean
//! over the hemisphere is exactly one: under even light an element takes in and sends
//! out what `ρ` says. What the separable form misses is where the light goes by where it
//! came from: light arriving near the normal is sent on as even light would leave, some
//! of it towards grazing by the specular lobe's forward scattering of grazing light (a
//! wall's foot lit by a floor under a high sun: 7 % too bright, `tests/corner.rs`).

use std::collections::HashMap;

use glam::Vec3;
use holocave_scene::Scene;
use rayon::prelude::*;

use crate::surface::{TOWARDS_STEPS, albedo_key_of, seen_at, table_step, towards_table};
use crate::tiles::Tiles;

const NONE: u32 = u32::MAX;

/// One element as the propagation's senders read it.
#[derive(Clone, Copy, Debug)]
struct Facing {
    /// Its shading normal at its centre.
    normal: Vec3,
    /// Its base colour there.
    base: Vec3,
    /// One over its profile's cosine-weighted mean for that base colour.
    per_mean: Vec3,
    /// Its material's profile; [`NONE`]: it sends evenly (Lambertian, a tile's, a delta
    /// surface's, or black).
    profile: u32,
}

/// A directional albedo over `cos θ_o`: `a + b · base` at [`TOWARDS_STEPS`] views.
struct Profile {
    steps: Vec<(Vec3, Vec3)>,
    /// `∫ (a + b · base)(c) 2c dc`'s `a` and `b`: the mean weighted by the cosine.
    mean: (Vec3, Vec3),
}

impl Profile {
    fn new(steps: Vec<(Vec3, Vec3)>) -> Self {
        // The interpolated table's cosine-weighted mean, by the midpoint rule on a grid
        // far finer than the table (each of its pieces is linear).
        const N: usize = 4096;
        let mut mean = (Vec3::ZERO, Vec3::ZERO);
        for k in 0..N {
            let c = (k as f32 + 0.5) / N as f32;
            let (a, b) = interpolate(&steps, c);
            let w = 2.0 * c / N as f32;
            mean = (mean.0 + a * w, mean.1 + b * w);
        }
        Profile { steps, mean }
    }

    /// Whether every view gets the same: a Lambertian material.
    fn is_even(&self) -> bool {
        let (a0, b0) = self.steps[0];
        (self.steps.iter()).all(|(a, b)| a.abs_diff_eq(a0, 1e-6) && b.abs_diff_eq(b0, 1e-6))
    }
}

/// `a` and `b` of a table at `cos`, linear between its steps.
fn interpolate(steps: &[(Vec3, Vec3)], cos: f32) -> (Vec3, Vec3) {
    let (i, t) = table_step(cos, TOWARDS_STEPS);
    let (lo, hi) = (steps[i], steps[i + 1]);
    (lo.0.lerp(hi.0, t), lo.1.lerp(hi.1, t))
}

/// Every element's profile of directions.
pub struct Exitance {
    facing: Vec<Facing>,
    profiles: Vec<Profile>,
}

impl Exitance {
    /// The profiles of the elements whose centres are `centre` (triangle and
    /// barycentrics); the elements with a tile (they send what their tile holds) and
    /// those not `needed` (black) send evenly.
    pub fn new(scene: &Scene, centre: &[(u32, f32, f32)], tiles: &Tiles, needed: &[bool]) -> Self {
        let seen: Vec<Option<_>> = (centre.par_iter().enumerate())
            .map(|(e, &(t, u, v))| {
                let s = seen_at(scene, t, u, v);
                let sends = !s.delta && tiles.of(e as u32).is_none() && needed[e];
                sends.then(|| (albedo_key_of(&s.params), s.params, s.shading_normal))
            })
            .collect();
        let mut index = HashMap::new();
        let mut profiles: Vec<Profile> = Vec::new();
        for (key, params, _) in seen.iter().flatten() {
            index.entry(*key).or_insert_with(|| {
                profiles.push(Profile::new(towards_table(params)));
                profiles.len() as u32 - 1
            });
        }
        let facing = (seen.par_iter())
            .map(|s| match s {
                Some((key, params, normal)) if !profiles[index[key] as usize].is_even() => {
                    let profile = index[key];
                    let (a, b) = profiles[profile as usize].mean;
                    let mean = a + b * params.base_color;
                    let per_mean = Vec3::select(mean.cmpgt(Vec3::ZERO), mean.recip(), Vec3::ZERO);
                    Facing {
                        normal: *normal,
                        base: params.base_color,
                        per_mean,
                        profile,
                    }
                }
                _ => Facing {
                    normal: Vec3::ZERO,
                    base: Vec3::ZERO,
                    per_mean: Vec3::ZERO,
                    profile: NONE,
                },
            })
            .collect();
        Exitance { facing, profiles }
    }

    /// `a(θ)` of element `e` for the direction `dir` (either way along it): its
    /// directional albedo there over its cosine-weighted mean (1 for an element that
    /// takes and sends evenly). What it sends along `dir` per unit of its `B`, and what
    /// light arriving along `dir` counts per unit of irradiance.
    pub fn towards(&self, e: u32, dir: Vec3) -> Vec3 {
        let Some(f) = self.facing.get(e as usize) else {
            return Vec3::ONE;
        };
        if f.profile == NONE {
            return Vec3::ONE;
        }
        let steps = &self.profiles[f.profile as usize].steps;
        let (a, b) = interpolate(steps, f.normal.dot(dir).abs());
        (a + b * f.base) * f.per_mean
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use holocave_scene::SurfaceParams;

    fn white_matt(specular: f32) -> SurfaceParams {
        SurfaceParams {
            base_color: Vec3::splat(0.9),
            metallic: 0.0,
            roughness: 0.968,
            emission: Vec3::ZERO,
            specular,
            specular_color: Vec3::ONE,
            transmission: 0.0,
            ior: 1.5,
        }
    }

    /// The profile of the breakfast room's walls falls towards grazing exits and its
    /// cosine-weighted mean is one (the element sends out all of `B`); a Lambertian one
    /// is even.
    #[test]
    fn a_rough_dielectric_sends_less_towards_grazing_and_all_of_its_light_in_all() {
        let profile = Profile::new(towards_table(&white_matt(1.0)));
        let base = Vec3::splat(0.9);
        let mean = profile.mean.0 + profile.mean.1 * base;
        let at = |c: f32| {
            let (a, b) = interpolate(&profile.steps, c);
            (a + b * base) / mean
        };
        assert!(
            at(0.05).x < 0.4 && at(0.1).x < 0.6,
            "{} {}",
            at(0.05),
            at(0.1)
        );
        assert!(at(1.0).x > 1.0 && at(1.0).x < 1.1, "{}", at(1.0));
        // ∫ ratio 2c dc = 1, by a rule independent of the one the mean was taken with.
        let n = 1000;
        let sum: f32 = (0..n)
            .map(|k| {
                let c = (k as f32 + 0.5) / n as f32;
                at(c).x * 2.0 * c / n as f32
            })
            .sum();
        assert!((sum - 1.0).abs() < 1e-3, "{sum}");
        assert!(!profile.is_even());
        assert!(Profile::new(towards_table(&white_matt(0.0))).is_even());
    }
}
