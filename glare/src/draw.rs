//! Drawing a fisheye's radiance, in the scene's units: as the walls draw it (the light
//! field's remainder plus the exact direct light per pixel, the caustics, the tiles'
//! albedo: `vlf`'s [`WallPass::radiance`], the one composition of a wall's radiance that
//! the walls, `holocave vlf view` and `compare` draw through) or by path tracing (the tracer's
//! [`Tracer::trace_one`], the reference). Both take their rays by direction, so no
//! planar view is needed.
//!
//! Each pixel is the mean of `k × k` (light field) or `spp` (path tracing) rays through
//! points spread over the pixel by the 2-D R sequence (Roberts' additive recurrence on the
//! plastic number), those outside the 180° circle left out; a pixel whose centre is
//! outside the circle is black (it is not part of the view).
//!
//! **The sun.** The sun's disc (0.53°) is smaller than a pixel at most sizes (0.7° at
//! 256 × 256) and its radiance some 10⁵ times the sky's: a pixel's few rays would either
//! miss it or count it over the whole pixel (at 128 × 128 with one ray a pixel, Ev in the
//! breakfast room was 14 000 lx or 800 000 lx depending on where the centre ray fell).
//! So each pixel's integral is split (stratified) into the part outside the disc and the
//! part inside: the pixel's rays that fall in the disc are dropped (the pixel's mean is
//! over all its rays, so they count as zero), and [`SUN_RAYS`] rays spread evenly over the
//! disc's solid angle `ω☉` (through the same drawing, so the blinds and the sky behind
//! them are seen as they are) each add `f · ω☉ / SUN_RAYS` to the pixel they fall in,
//! divided by that pixel's solid angle. The sun's `L ω` (its illuminance, and the glare
//! sums' part that is linear in it) is then right at any size; its luminance is still
//! spread over whole pixels.
//!
//! (Each pixel's rays are spread evenly over its square in the image, not in solid
//! angle: the mapping's Jacobian varies by about `k²` across a pixel, negligible.)

use glam::{DVec3, Vec2, Vec3};
use holocave_scene::{Ray, Scene};
use holocave_tracer::Tracer;
use holocave_tracer::film::Image;
use holocave_tracer::frame::Frame;
use holocave_tracer::sampling::uniform_cone;
use holocave_vlf::view::ReflectionFrames;
use holocave_vlf::{FrameContext, Visibility, WallPass};
use rayon::prelude::*;
use std::sync::Arc;

use crate::fisheye::Fisheye;

/// How a fisheye's radiance is drawn.
pub enum Drawing {
    /// As the walls draw: the light field's lookups, with the direct light computed per
    /// pixel where the pass takes it ([`WallPass::radiance`]).
    LightField {
        pass: Box<WallPass>,
        /// Direct-light estimates averaged per lookup (what a still wall has after
        /// `estimates − first_estimates + 1` frames).
        estimates: u32,
        /// The frames of a still view whose glossy directions the lookups take.
        reflections: ReflectionFrames,
        /// Lookups per pixel along each axis.
        k: u32,
    },
    /// Path traced with `spp` paths per pixel.
    PathTraced {
        /// Boxed: the variant would otherwise be far larger than the other.
        tracer: Box<Tracer>,
        spp: u32,
        seed: u64,
    },
}

/// Rays spread over the sun's disc.
pub const SUN_RAYS: u32 = 4096;

/// The generator of the 2-D R sequence (the plastic number).
const PLASTIC: f64 = 1.324_717_957_244_746;

/// Point `i` of the 2-D R sequence in the unit square.
pub(crate) fn r2(i: u32) -> (f64, f64) {
    let (a1, a2) = (1.0 / PLASTIC, 1.0 / (PLASTIC * PLASTIC));
    (
        (0.5 + a1 * f64::from(i)).fract(),
        (0.5 + a2 * f64::from(i)).fract(),
    )
}

/// The rays of pixel `(x, y)`: `count` points spread over it, those in the circle.
pub(crate) fn pixel_rays(fisheye: &Fisheye, x: u32, y: u32, count: u32) -> Vec<Ray> {
    if fisheye.pixel_direction(x, y).is_none() {
        return Vec::new();
    }
    let eye = fisheye.eye.as_vec3();
    (0..count.max(1))
        .filter_map(|i| {
            let (u, v) = if count <= 1 { (0.5, 0.5) } else { r2(i) };
            let d = fisheye.direction(f64::from(x) + u, f64::from(y) + v)?;
            Some(Ray::new(eye, to_f32(d)))
        })
        .collect()
}

/// A unit direction in f32, with −0 made +0 (the BVH walk's pitfall with −0).
fn to_f32(d: DVec3) -> Vec3 {
    d.as_vec3().normalize() + Vec3::ZERO
}

impl Drawing {
    /// The light field drawn as the walls draw it after `frames` frames of a still view,
    /// from a light field opened for `scene`: with the direct light per pixel unless
    /// `no_direct` or the scene has no light that pass computes.
    pub fn light_field(
        scene: Arc<Scene>,
        opened: holocave_vlf::baked::Opened,
        no_direct: bool,
        frames: u32,
        k: u32,
    ) -> Self {
        let file = opened.file;
        let visibility = Visibility::new(scene, opened.elements, opened.tiles);
        Drawing::of_state(
            visibility,
            (&file.settings, &file.state),
            no_direct,
            frames,
            k,
        )
    }

    /// As [`Drawing::light_field`], from a bake's settings and state and its visibility
    /// (its element layout and tiles for the scene).
    pub fn of_state(
        visibility: Visibility,
        (settings, state): (&holocave_vlf::Settings, &holocave_vlf::State),
        no_direct: bool,
        frames: u32,
        k: u32,
    ) -> Self {
        // The sky is drawn from the field, as on the walls by default; only the sky per
        // pixel can make a wall pass fail (a state without its sky part).
        let pass = match WallPass::new(visibility, settings, state, false) {
            Ok(pass) => pass.with_direct(!no_direct),
            Err(e) => unreachable!("a wall pass without the sky per pixel: {e}"),
        };
        Drawing::LightField {
            estimates: pass.estimates_after(frames),
            pass: Box::new(pass),
            reflections: ReflectionFrames::after(frames),
            k: k.max(1),
        }
    }

    /// The scene drawn.
    fn scene(&self) -> &Scene {
        match self {
            Drawing::LightField { pass, .. } => pass.scene(),
            Drawing::PathTraced { tracer, .. } => tracer.scene(),
        }
    }

    /// The sun's unit direction and `1 − cos` of its angular radius, when it is in front
    /// of the eye.
    fn sun(&self, fisheye: &Fisheye) -> Option<(DVec3, f64)> {
        let s = self.scene().daylight.sun.as_ref()?;
        let d = s.direction.as_dvec3().normalize();
        (d.dot(fisheye.look) > -f64::from(s.angular_radius))
            .then(|| (d, f64::from(s.one_minus_cos_radius())))
    }

    /// The radiance along `ray`, the `index`-th ray of pixel or set `seed` (drawn from the
    /// light field: with sample sequence `seed · 2¹⁶ + index`).
    pub fn radiance(&self, ray: &Ray, seed: u64, index: u64) -> Vec3 {
        match self {
            Drawing::LightField {
                pass,
                estimates,
                reflections,
                ..
            } => {
                let ctx = FrameContext {
                    values: pass.values(),
                    reflections,
                    estimates: *estimates,
                };
                pass.radiance(ctx, *ray, seed.wrapping_mul(0x1_0000).wrapping_add(index))
            }
            Drawing::PathTraced {
                tracer, seed: base, ..
            } => {
                let s = base ^ seed.wrapping_mul(0x9E37_79B9_7F4A_7C15);
                Vec3::from(tracer.trace_one(ray, s, index).radiance)
            }
        }
    }

    /// Rays per pixel.
    fn rays_per_pixel(&self) -> u32 {
        match self {
            Drawing::LightField { k, .. } => k * k,
            Drawing::PathTraced { spp, .. } => *spp,
        }
    }

    /// The radiance of every pixel of `fisheye`, rows from the top.
    pub fn draw(&self, fisheye: &Fisheye) -> Image {
        let n = fisheye.size;
        let sun = self.sun(fisheye);
        let count = self.rays_per_pixel();
        let mut image = Image::new(n, n);
        image
            .pixels
            .par_chunks_mut(n as usize)
            .enumerate()
            .for_each(|(y, row)| {
                let y = y as u32;
                for (x, px) in row.iter_mut().enumerate() {
                    let x = x as u32;
                    let rays = pixel_rays(fisheye, x, y, count);
                    let seed = u64::from(y) * u64::from(n) + u64::from(x);
                    let sum: Vec3 = rays
                        .iter()
                        .enumerate()
                        .filter(|(_, r)| {
                            sun.is_none_or(|(d, one_minus_cos)| {
                                r.dir.as_dvec3().dot(d) < 1.0 - one_minus_cos
                            })
                        })
                        .map(|(i, r)| self.radiance(r, seed, i as u64))
                        .sum();
                    *px = sum / rays.len().max(1) as f32;
                }
            });
        if let Some((d, one_minus_cos)) = sun {
            self.add_sun(fisheye, &mut image, d, one_minus_cos);
        }
        image
    }

    /// The disc's part of each pixel it covers: [`SUN_RAYS`] rays spread evenly over its
    /// solid angle, each adding `f · ω☉ / SUN_RAYS / ω_pixel` to its pixel.
    fn add_sun(&self, fisheye: &Fisheye, image: &mut Image, d: DVec3, one_minus_cos: f64) {
        let n = fisheye.size;
        let omega_sun = std::f64::consts::TAU * one_minus_cos;
        let frame = Frame::new(d.as_vec3());
        let eye = fisheye.eye.as_vec3();
        // The sun's rays get seeds past every pixel's.
        let seed = u64::from(n) * u64::from(n);
        let hits: Vec<(usize, Vec3)> = (0..SUN_RAYS)
            .into_par_iter()
            .filter_map(|i| {
                let (u, v) = r2(i);
                let dir = frame.to_world(uniform_cone(
                    Vec2::new(u as f32, v as f32),
                    one_minus_cos as f32,
                ));
                let (px, py) = fisheye.position(dir.as_dvec3())?;
                let (x, y) = (px.floor(), py.floor());
                if x < 0.0 || y < 0.0 || x >= f64::from(n) || y >= f64::from(n) {
                    return None;
                }
                let (x, y) = (x as u32, y as u32);
                fisheye.pixel_direction(x, y)?;
                let ray = Ray::new(eye, dir.normalize() + Vec3::ZERO);
                Some((
                    (y * n + x) as usize,
                    self.radiance(&ray, seed, u64::from(i)),
                ))
            })
            .collect();
        for (p, f) in hits {
            let omega = fisheye.solid_angle(p as u32 % n, p as u32 / n);
            image.pixels[p] += f * (omega_sun / f64::from(SUN_RAYS) / omega) as f32;
        }
    }
}
