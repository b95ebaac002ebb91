//! Drawing a fisheye's radiance, in the scene's units: as the walls draw it (the light
//! field's remainder plus the exact direct light per pixel, `vlf`'s
//! [`Visibility::lookup_and_point`], [`shade_one`] and [`PixelDirect::mean`], the same
//! calls `holocave vlf view` makes through a wall) or by path tracing (the tracer's
//! [`Tracer::trace_serial`], the reference). Both take their rays by direction, so no
//! planar view is needed.
//!
//! Each pixel is the mean of `k × k` (light field) or `spp` (path tracing) rays through
//! points spread over the pixel by the 2-D R sequence (Roberts' additive recurrence on the
//! plastic number), those outside the 180° circle left out; a pixel whose centre is
//! outside the circle is black (it is not part of the view).

use glam::{DVec3, Vec3};
use holocave_scene::{Ray, Scene};
use holocave_tracer::Tracer;
use holocave_tracer::film::Image;
use holocave_vlf::view::shade_one;
use holocave_vlf::{PixelDirect, Visibility};
use rayon::prelude::*;
use std::sync::Arc;

use crate::fisheye::Fisheye;

/// How a fisheye's radiance is drawn.
pub enum Drawing {
    /// As the walls draw: the light field's lookups, with the direct light computed per
    /// pixel when `direct` is given (then `values` are the light field's indirect values,
    /// [`holocave_vlf::State::indirect_values`], else all of them,
    /// [`holocave_vlf::State::values`]).
    LightField {
        /// Boxed: the variant would otherwise be far larger than the other.
        visibility: Box<Visibility>,
        values: Vec<[f32; 3]>,
        direct: Option<PixelDirect>,
        /// Direct-light estimates averaged per lookup (what a still wall has after
        /// `estimates − first_estimates + 1` frames).
        estimates: u32,
        /// Lookups per pixel along each axis.
        k: u32,
    },
    /// Path traced with `spp` paths per pixel.
    PathTraced { tracer: Tracer, spp: u32, seed: u64 },
}

/// The generator of the 2-D R sequence (the plastic number).
const PLASTIC: f64 = 1.324_717_957_244_746;

/// Point `i` of the 2-D R sequence in the unit square.
fn r2(i: u32) -> (f64, f64) {
    let (a1, a2) = (1.0 / PLASTIC, 1.0 / (PLASTIC * PLASTIC));
    (
        (0.5 + a1 * f64::from(i)).fract(),
        (0.5 + a2 * f64::from(i)).fract(),
    )
}

/// The rays of pixel `(x, y)`: `count` points spread over it, those in the circle.
fn pixel_rays(fisheye: &Fisheye, x: u32, y: u32, count: u32) -> Vec<Ray> {
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
    /// The light field drawn as the walls draw it, from a light field opened for `scene`
    /// (`state` its baked state): with the direct light per pixel unless `no_direct` or
    /// the scene has no light that pass computes.
    pub fn light_field(
        scene: Arc<Scene>,
        opened: holocave_vlf::baked::Opened,
        no_direct: bool,
        frames: u32,
        k: u32,
    ) -> Self {
        let direct = PixelDirect::new(scene.clone());
        let use_direct = !no_direct && !direct.is_empty();
        let state = &opened.file.state;
        let values = if use_direct {
            state.indirect_values()
        } else {
            state.values()
        };
        let estimates = direct.first_estimates() + frames.max(1) - 1;
        Drawing::LightField {
            visibility: Box::new(Visibility::new(scene, opened.elements, opened.tiles)),
            values,
            direct: use_direct.then_some(direct),
            estimates,
            k: k.max(1),
        }
    }

    /// The radiance of every pixel of `fisheye`, rows from the top.
    pub fn draw(&self, fisheye: &Fisheye) -> Image {
        let n = fisheye.size;
        let mut image = Image::new(n, n);
        image
            .pixels
            .par_chunks_mut(n as usize)
            .enumerate()
            .for_each(|(y, row)| {
                let y = y as u32;
                for (x, px) in row.iter_mut().enumerate() {
                    *px = self.pixel(fisheye, x as u32, y);
                }
            });
        image
    }

    /// The radiance of pixel `(x, y)`.
    fn pixel(&self, fisheye: &Fisheye, x: u32, y: u32) -> Vec3 {
        let seed = u64::from(y) * u64::from(fisheye.size) + u64::from(x);
        match self {
            Drawing::LightField {
                visibility,
                values,
                direct,
                estimates,
                k,
            } => {
                let rays = pixel_rays(fisheye, x, y, k * k);
                let sum: Vec3 = rays
                    .iter()
                    .enumerate()
                    .map(|(s, ray)| {
                        let (l, p) = visibility.lookup_and_point(*ray);
                        let mut c = shade_one(&l, values);
                        if let (Some(direct), Some(p)) = (direct, p) {
                            let seed = seed * u64::from(k * k) + s as u64;
                            c += direct.mean(&p, seed, 0, *estimates);
                        }
                        c
                    })
                    .sum();
                sum / rays.len().max(1) as f32
            }
            Drawing::PathTraced {
                tracer,
                spp,
                seed: base,
            } => {
                let rays = pixel_rays(fisheye, x, y, *spp);
                let samples =
                    tracer.trace_serial(&rays, base ^ seed.wrapping_mul(0x9E37_79B9_7F4A_7C15));
                let sum: Vec3 = samples.iter().map(|s| Vec3::from(s.radiance)).sum();
                sum / rays.len().max(1) as f32
            }
        }
    }
}
