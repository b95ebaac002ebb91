//! One hour's fisheye from a view's daylight coefficients: the rows times the hour's sky
//! patches and sun, plus the parts kept exact (the sky seen straight, the sun on the first
//! surface with its shadow ray, the sun's disc in view).

use glam::{Vec2, Vec3};
use holocave_scene::color::luminance;
use holocave_scene::daylight::{Sky, Sun};
use holocave_scene::{Ray, Scene};
use holocave_tracer::film::Image;
use holocave_tracer::frame::Frame;
use holocave_tracer::sampling::uniform_cone;
use rayon::prelude::*;

use super::coefficients::{ViewCoefficients, reflected};
use super::patches::{self, PATCHES};
use crate::draw::r2;

/// Rays spread over the sun's disc, for the part of it the eye sees.
pub const DISC_RAYS: u32 = 256;

/// An hour's daylight, as the scene is loaded at that hour.
pub struct HourLight<'a> {
    pub sun: Option<&'a Sun>,
    pub sky: Option<&'a Sky>,
}

impl HourLight<'_> {
    /// The hour's value of each column of `coefficients`' rows.
    fn column_values(&self, coefficients: &ViewCoefficients) -> Vec<f32> {
        let columns = &coefficients.columns;
        let mut v = vec![0.0; columns.width()];
        if let Some(sky) = self.sky {
            v[..PATCHES].copy_from_slice(&patches::mean_luminances(sky));
        }
        if let Some(sun) = self.sun {
            let here = patches::patch_of(sun.direction);
            if let Some(c) = columns.sun_patches.iter().position(|&p| p == here) {
                v[PATCHES + c] = irradiance(sun);
            }
        }
        v[columns.lamps()] = 1.0;
        v
    }

    /// The fisheye's radiance at this hour (grey: the luminance in the scene's units).
    pub fn draw(&self, scene: &Scene, coefficients: &ViewCoefficients) -> Image {
        let values = self.column_values(coefficients);
        let n = coefficients.fisheye.size;
        let mut pixels: Vec<f32> = (0..(n * n) as usize)
            .into_par_iter()
            .map(|i| dot(coefficients.row(i), &values))
            .collect();
        if let Some(sky) = self.sky {
            for s in &coefficients.sky_seen {
                pixels[s.pixel as usize] += s.weight * luminance(sky.radiance(s.direction));
            }
        }
        if let Some(sun) = self.sun {
            self.add_sun_on_surfaces(scene, coefficients, sun, &mut pixels);
            add_disc(scene, coefficients, sun, &mut pixels);
        }
        let mut image = Image::new(n, n);
        for (px, v) in image.pixels.iter_mut().zip(pixels) {
            *px = Vec3::splat(v);
        }
        image
    }

    /// The sun on each pixel's first surface, its shadow ray traced.
    fn add_sun_on_surfaces(
        &self,
        scene: &Scene,
        coefficients: &ViewCoefficients,
        sun: &Sun,
        pixels: &mut [f32],
    ) {
        let e = irradiance(sun);
        let wi = sun.direction;
        let lit: Vec<(u32, f32)> = (coefficients.first_surfaces)
            .par_iter()
            .filter_map(|s| {
                let f = reflected(&s.bsdf, &s.frame, s.wo, wi, s.geometric_normal)?;
                let y = luminance(s.throughput * f) * e;
                let ray = Ray::leaving(s.position, s.geometric_normal, wi);
                (y > 0.0 && !scene.occluded(&ray, f32::INFINITY)).then_some((s.pixel, y))
            })
            .collect();
        for (p, y) in lit {
            pixels[p as usize] += y;
        }
    }
}

/// The sun's normal irradiance (its disc's radiance times its solid angle), as luminance.
fn irradiance(sun: &Sun) -> f32 {
    luminance(sun.radiance) * sun.solid_angle()
}

fn dot(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The sun's disc where the eye sees it: [`DISC_RAYS`] rays over its solid angle, each
/// unblocked one adding its share of the disc's `L ω` to the pixel it falls in, divided by
/// that pixel's solid angle (as `draw` counts the disc, but blocked by glass, which `draw`
/// sees through).
fn add_disc(scene: &Scene, coefficients: &ViewCoefficients, sun: &Sun, pixels: &mut [f32]) {
    let fisheye = &coefficients.fisheye;
    let n = fisheye.size;
    let one_minus_cos = sun.one_minus_cos_radius();
    let share = irradiance(sun) / DISC_RAYS as f32;
    let frame = Frame::new(sun.direction);
    let eye = fisheye.eye.as_vec3();
    for i in 0..DISC_RAYS {
        let (u, v) = r2(i);
        let dir = frame.to_world(uniform_cone(Vec2::new(u as f32, v as f32), one_minus_cos));
        let Some((px, py)) = fisheye.position(dir.as_dvec3()) else {
            continue;
        };
        let (x, y) = (px.floor(), py.floor());
        if x < 0.0 || y < 0.0 || x >= f64::from(n) || y >= f64::from(n) {
            continue;
        }
        let (x, y) = (x as u32, y as u32);
        if fisheye.pixel_direction(x, y).is_none()
            || scene.occluded(&Ray::new(eye, dir.normalize() + Vec3::ZERO), f32::INFINITY)
        {
            continue;
        }
        pixels[(y * n + x) as usize] += share / fisheye.solid_angle(x, y) as f32;
    }
}
