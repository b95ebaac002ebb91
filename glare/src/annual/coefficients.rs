//! A view's daylight coefficients: what each pixel of its fisheye receives from each patch
//! of the sky at unit luminance, from a sun of unit irradiance in each patch the sun
//! visits, and from the scene's own lamps. The pixel's luminance at any hour is then a
//! dot product with that hour's sky and sun (Radiance's daylight-coefficient method, as
//! `rcontrib` computes its matrix, Tregenza & Waters 1983), plus the parts that are kept
//! exact per hour because they are sharp ([`super::hour`]):
//!
//! - the sky seen straight, or through mirrors and glass (a pixel's mean direction);
//! - the sun on the first surface a pixel sees (its centre ray's surface, BSDF kept);
//! - the sun's disc in view.
//!
//! Everything after the first surface goes through the coefficients: the sky by next-event
//! estimation (cosine-weighted, MIS against the BSDF's own sampling, which also ends in the
//! patch its escaping ray meets), the sun by a shadow ray to each visited patch's centre
//! (the sun's light after one bounce moves by up to a patch's half diagonal, about 8.5°),
//! the lamps: emitting surfaces when a path meets them, point, spot and directional lights
//! by a shadow ray from every surface. The sun and sky are grey (the Perez model gives irradiance, not colour),
//! so a coefficient is the luminance of a path's RGB throughput.

use glam::{DVec3, Vec2, Vec3};
use holocave_scene::color::luminance;
use holocave_scene::{Ray, Scene};
use holocave_tracer::bsdf::Bsdf;
use holocave_tracer::frame::Frame;
use holocave_tracer::integrator::light_unblocked;
use holocave_tracer::lights::Lights;
use holocave_tracer::sampling::{cosine_hemisphere, cosine_hemisphere_pdf, power_heuristic};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;
use rayon::prelude::*;

use super::patches::{self, PATCHES};
use crate::draw::pixel_rays;
use crate::fisheye::Fisheye;

/// Surfaces a path may meet, delta bounces included.
const MAX_DEPTH: u32 = 16;
/// From this depth on, Russian roulette.
const ROULETTE_DEPTH: u32 = 3;

/// The columns of a pixel's row: the sky's patches and the ground, then a sun in each
/// visited patch, then the lamps (whose coefficient is 1 at every hour).
#[derive(Clone, Debug)]
pub struct Columns {
    /// The sky patches the sun stands in at some hour asked for.
    pub sun_patches: Vec<usize>,
}

impl Columns {
    pub fn width(&self) -> usize {
        PATCHES + self.sun_patches.len() + 1
    }

    pub fn lamps(&self) -> usize {
        self.width() - 1
    }
}

/// The first surface a pixel's centre ray meets (through mirrors and glass): where the
/// sun's light is computed exactly at each hour.
#[derive(Clone, Copy, Debug)]
pub struct FirstSurface {
    pub pixel: u32,
    pub position: Vec3,
    pub geometric_normal: Vec3,
    pub frame: Frame,
    pub wo: Vec3,
    pub bsdf: Bsdf,
    /// The camera ray's throughput up to the surface (the mirrors' and glass's colour).
    pub throughput: Vec3,
}

/// The sky a pixel sees straight (or through mirrors and glass): its rays' mean escaping
/// direction, and the share of the pixel's light it carries.
#[derive(Clone, Copy, Debug)]
pub struct SkySeen {
    pub pixel: u32,
    pub direction: Vec3,
    pub weight: f32,
}

/// A fisheye's daylight coefficients.
pub struct ViewCoefficients {
    pub fisheye: Fisheye,
    pub columns: Columns,
    /// One row of `columns.width()` per pixel, rows of the image from the top.
    pub rows: Vec<f32>,
    pub first_surfaces: Vec<FirstSurface>,
    pub sky_seen: Vec<SkySeen>,
}

/// What one pixel's paths gave.
struct PixelResult {
    row: Vec<f32>,
    first: Option<FirstSurface>,
    sky: Option<SkySeen>,
}

impl ViewCoefficients {
    /// The coefficients of `fisheye` in `scene` by `spp` paths per pixel (seeded by `seed`),
    /// with a sun column for each of `sun_patches`.
    pub fn trace(
        scene: &Scene,
        fisheye: &Fisheye,
        sun_patches: Vec<usize>,
        spp: u32,
        seed: u64,
    ) -> Self {
        let columns = Columns { sun_patches };
        let sun_dirs: Vec<Vec3> = columns
            .sun_patches
            .iter()
            .map(|&p| patches::centre(p))
            .collect();
        let lights = Lights::new(scene);
        let n = fisheye.size;
        let results: Vec<PixelResult> = (0..n * n)
            .into_par_iter()
            .map(|i| {
                let tracer = PixelPaths {
                    scene,
                    columns: &columns,
                    sun_dirs: &sun_dirs,
                    lights: &lights,
                };
                tracer.pixel(fisheye, i, spp, seed)
            })
            .collect();
        let mut rows = Vec::with_capacity(results.len() * columns.width());
        let (mut first_surfaces, mut sky_seen) = (Vec::new(), Vec::new());
        for r in results {
            rows.extend_from_slice(&r.row);
            first_surfaces.extend(r.first);
            sky_seen.extend(r.sky);
        }
        ViewCoefficients {
            fisheye: fisheye.clone(),
            columns,
            rows,
            first_surfaces,
            sky_seen,
        }
    }

    /// Pixel `i`'s row.
    pub fn row(&self, i: usize) -> &[f32] {
        let w = self.columns.width();
        &self.rows[i * w..(i + 1) * w]
    }
}

/// The paths of one pixel, and what they add to its row.
struct PixelPaths<'a> {
    scene: &'a Scene,
    columns: &'a Columns,
    sun_dirs: &'a [Vec3],
    /// The scene's lights, for its point, spot and directional ones.
    lights: &'a Lights,
}

/// One path's state between surfaces.
struct PathState {
    ray: Ray,
    throughput: Vec3,
    /// Non-delta surfaces met so far.
    surfaces: u32,
    /// The MIS weight an escape along `ray` takes against the sky's sampling at the last
    /// surface (1 when the last bounce was a delta one, or the camera ray).
    escape_weight: f32,
}

impl PixelPaths<'_> {
    fn pixel(&self, fisheye: &Fisheye, i: u32, spp: u32, seed: u64) -> PixelResult {
        let n = fisheye.size;
        let mut result = PixelResult {
            row: vec![0.0; self.columns.width()],
            first: None,
            sky: None,
        };
        let rays = pixel_rays(fisheye, i % n, i / n, spp);
        if rays.is_empty() {
            return result;
        }
        let mut sky = (DVec3::ZERO, 0.0f32);
        for (k, ray) in rays.iter().enumerate() {
            let mut rng = Pcg32::seed_from_u64(
                seed ^ (u64::from(i) << 20 | k as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
            );
            let centre = k == 0;
            self.path(*ray, &mut rng, &mut result, centre, i, &mut sky);
        }
        let count = rays.len() as f32;
        result.row.iter_mut().for_each(|v| *v /= count);
        if sky.1 > 0.0 {
            result.sky = Some(SkySeen {
                pixel: i,
                direction: sky.0.normalize().as_vec3(),
                weight: sky.1 / count,
            });
        }
        result
    }

    /// One path from the eye along `ray`; `centre`: the pixel's centre ray, whose first
    /// surface is kept for the sun. `sky` sums the straight-seen sky's directions.
    fn path(
        &self,
        ray: Ray,
        rng: &mut Pcg32,
        out: &mut PixelResult,
        centre: bool,
        pixel: u32,
        sky: &mut (DVec3, f32),
    ) {
        let scene = self.scene;
        let mut s = PathState {
            ray,
            throughput: Vec3::ONE,
            surfaces: 0,
            escape_weight: 1.0,
        };
        for depth in 0..MAX_DEPTH {
            let Some(hit) = scene.closest_hit(&s.ray, f32::INFINITY) else {
                let y = luminance(s.throughput);
                if s.surfaces == 0 {
                    sky.0 += s.ray.dir.as_dvec3() * f64::from(y);
                    sky.1 += y;
                } else {
                    out.row[patches::patch_of(s.ray.dir)] += y * s.escape_weight;
                }
                return;
            };
            let sp = scene.surface(&hit);
            let material = &scene.materials[sp.material as usize];
            let params = material.params(&scene.textures, sp.uv);
            let (wo, ng) = (-s.ray.dir, sp.geometric_normal);
            if params.emission.max_element() > 0.0 && (ng.dot(wo) > 0.0 || material.double_sided) {
                let lamps = self.columns.lamps();
                out.row[lamps] += luminance(s.throughput * params.emission);
            }
            let bsdf = Bsdf::new(&params);
            let frame = Frame::new(sp.shading_normal);
            let mut sky_sampled = false;
            if bsdf.has_non_delta() {
                if s.surfaces == 0 && centre {
                    out.first = Some(FirstSurface {
                        pixel,
                        position: sp.position,
                        geometric_normal: ng,
                        frame,
                        wo,
                        bsdf,
                        throughput: s.throughput,
                    });
                }
                let v = Vertex {
                    bsdf,
                    frame,
                    wo,
                    p: sp.position,
                    ng,
                };
                if s.surfaces > 0 {
                    self.add_suns(&mut out.row, &s, &v);
                }
                self.add_punctual(&mut out.row, &s, &v);
                sky_sampled = self.add_sky(&mut out.row, &s, &v, rng);
                s.surfaces += 1;
            }
            let uc: f32 = rng.random();
            let Some(bs) = bsdf.sample(
                frame.to_local(wo),
                uc,
                Vec2::new(rng.random(), rng.random()),
            ) else {
                return;
            };
            let wi = frame.to_world(bs.wi).normalize();
            if !bsdf.transmits() && ng.dot(wi) * ng.dot(wo) <= 0.0 {
                return;
            }
            s.throughput *= bs.weight;
            if !s.throughput.is_finite() || s.throughput.max_element() <= 0.0 {
                return;
            }
            s.escape_weight = if bs.delta || !sky_sampled {
                1.0
            } else {
                power_heuristic(bs.pdf, sky_pdf(&frame, ng, wo, wi))
            };
            if depth + 1 >= ROULETTE_DEPTH {
                let p = s.throughput.max_element().min(0.95);
                if rng.random::<f32>() >= p {
                    return;
                }
                s.throughput /= p;
            }
            s.ray = Ray::leaving(sp.position, ng, wi);
        }
    }

    /// A sun of unit irradiance at each visited patch's centre, seen from a surface after
    /// the first.
    fn add_suns(&self, row: &mut [f32], s: &PathState, v: &Vertex) {
        for (c, &wi) in self.sun_dirs.iter().enumerate() {
            let Some(f) = reflected(&v.bsdf, &v.frame, v.wo, wi, v.ng) else {
                continue;
            };
            let y = luminance(s.throughput * f);
            if y > 0.0
                && !self
                    .scene
                    .occluded(&Ray::leaving(v.p, v.ng, wi), f32::INFINITY)
            {
                row[PATCHES + c] += y;
            }
        }
    }

    /// The point, spot and directional lights, each by its shadow ray (delta lights: no
    /// other strategy finds them), into the lamps' column.
    fn add_punctual(&self, row: &mut [f32], s: &PathState, v: &Vertex) {
        for i in 0..self.lights.punctual.len() {
            let Some(ls) = self.lights.sample_punctual(i, v.p) else {
                continue;
            };
            let Some(f) = reflected(&v.bsdf, &v.frame, v.wo, ls.wi, v.ng) else {
                continue;
            };
            let y = luminance(s.throughput * f * ls.contribution);
            if y > 0.0 && light_unblocked(self.scene, &ls, v.p, v.ng) {
                row[self.columns.lamps()] += y;
            }
        }
    }

    /// One cosine-weighted sample of the sky (and ground) patches; whether it was taken.
    fn add_sky(&self, row: &mut [f32], s: &PathState, v: &Vertex, rng: &mut Pcg32) -> bool {
        let (frame, ng, wo) = (&v.frame, v.ng, v.wo);
        if v.bsdf.transmits() {
            return false;
        }
        let side = Frame::new(front(frame.n, ng, wo));
        let wi = side.to_world(cosine_hemisphere(Vec2::new(rng.random(), rng.random())));
        let pdf = sky_pdf(frame, ng, wo, wi);
        if pdf <= 0.0 {
            return true;
        }
        let (f, bsdf_pdf) = v.bsdf.eval(frame.to_local(wo), frame.to_local(wi));
        if ng.dot(wi) * ng.dot(wo) <= 0.0 {
            return true;
        }
        let c = f * frame.n.dot(wi).abs() / pdf;
        let y = luminance(s.throughput * c);
        if y > 0.0
            && !self
                .scene
                .occluded(&Ray::leaving(v.p, ng, wi), f32::INFINITY)
        {
            row[patches::patch_of(wi)] += y * power_heuristic(pdf, bsdf_pdf);
        }
        true
    }
}

/// A non-delta surface a path meets: its scattering, shading frame, the direction the
/// path came back along, the point and its face normal.
struct Vertex {
    bsdf: Bsdf,
    frame: Frame,
    wo: Vec3,
    p: Vec3,
    ng: Vec3,
}

/// The shading normal turned to the side the surface is seen from.
fn front(n: Vec3, ng: Vec3, wo: Vec3) -> Vec3 {
    if ng.dot(wo) < 0.0 { -n } else { n }
}

/// The density of the sky's cosine-weighted sampling at `wi`.
fn sky_pdf(frame: &Frame, ng: Vec3, wo: Vec3, wi: Vec3) -> f32 {
    cosine_hemisphere_pdf(front(frame.n, ng, wo).dot(wi))
}

/// `f · |cos|` for light arriving from `wi`; `None` when an opaque surface is lit from
/// the side it is not seen from.
pub fn reflected(bsdf: &Bsdf, frame: &Frame, wo: Vec3, wi: Vec3, ng: Vec3) -> Option<Vec3> {
    if !bsdf.transmits() && ng.dot(wi) * ng.dot(wo) <= 0.0 {
        return None;
    }
    let (f, _) = bsdf.eval(frame.to_local(wo), frame.to_local(wi));
    Some(f * frame.n.dot(wi).abs())
}
