//! The path tracer: one path per ray, next-event estimation with multiple importance
//! sampling (power heuristic) against BSDF sampling, Russian roulette, and the virtual
//! distance through flat mirrors and flat glass.

use glam::{Vec2, Vec3};
use holocave_scene::{Ray, Scene};
use rand::Rng;
use rand_pcg::Pcg32;

use crate::bsdf::Bsdf;
use crate::frame::Frame;
use crate::lights::{LightSample, Lights};
use crate::sampling::power_heuristic;
use crate::{Sample, TraceSettings};

/// How far a new ray starts off its surface, along the face normal: relative to the
/// magnitude of the coordinates, so it stays above float spacing anywhere in the scene.
fn offset(p: Vec3, ng: Vec3, towards: Vec3) -> Vec3 {
    let eps = 1e-4 * (1.0 + p.abs().max_element());
    p + ng * (eps * ng.dot(towards).signum())
}

fn u2(rng: &mut Pcg32) -> Vec2 {
    Vec2::new(rng.random(), rng.random())
}

/// The state of one path between bounces.
struct Path<'a> {
    scene: &'a Scene,
    lights: &'a Lights,
    radiance: Vec3,
    throughput: Vec3,
}

impl Path<'_> {
    /// Adds the light arriving by one light sample, if the BSDF reflects it and nothing
    /// blocks it, weighted by MIS against BSDF sampling.
    fn add_light(
        &mut self,
        ls: LightSample,
        frame: &Frame,
        bsdf: &Bsdf,
        wo: Vec3,
        p: Vec3,
        ng: Vec3,
    ) {
        // Opaque surfaces only receive light on the side they are seen from.
        if !bsdf.transmits() && ng.dot(ls.wi) * ng.dot(wo) <= 0.0 {
            return;
        }
        let (f, bsdf_pdf) = bsdf.eval(frame.to_local(wo), frame.to_local(ls.wi));
        let cos = frame.n.dot(ls.wi).abs();
        let c = f * cos * ls.contribution;
        if c.max_element() <= 0.0 {
            return;
        }
        let origin = offset(p, ng, ls.wi);
        let tmax = if ls.dist.is_finite() {
            (ls.dist - 2e-4 * (1.0 + p.abs().max_element())).max(0.0)
        } else {
            f32::INFINITY
        };
        if self.scene.occluded(&Ray::new(origin, ls.wi), tmax) {
            return;
        }
        let w = if ls.pdf.is_infinite() {
            1.0
        } else {
            power_heuristic(ls.pdf, bsdf_pdf)
        };
        self.radiance += self.throughput * c * w;
    }

    /// Next-event estimation: one sample of each kind of light the scene has.
    fn sample_lights(
        &mut self,
        rng: &mut Pcg32,
        frame: &Frame,
        bsdf: &Bsdf,
        wo: Vec3,
        p: Vec3,
        ng: Vec3,
    ) {
        let lights = self.lights;
        if lights.has_area() {
            let uc = rng.random();
            if let Some(ls) = lights.sample_area(self.scene, p, uc, u2(rng)) {
                self.add_light(ls, frame, bsdf, wo, p, ng);
            }
        }
        for i in 0..lights.punctual.len() {
            if let Some(ls) = lights.sample_punctual(i, p) {
                self.add_light(ls, frame, bsdf, wo, p, ng);
            }
        }
        if let Some(ls) = lights.sample_sun(u2(rng)) {
            self.add_light(ls, frame, bsdf, wo, p, ng);
        }
        if lights.sky.is_some() {
            if let Some(ls) = lights.sample_sky(u2(rng)) {
                self.add_light(ls, frame, bsdf, wo, p, ng);
            }
        }
    }

    /// Light from the sun and sky along an escaping ray; `bsdf_pdf` is `None` after a
    /// delta bounce or for a camera ray (no light sampling could have found it).
    fn add_environment(&mut self, dir: Vec3, bsdf_pdf: Option<f32>) {
        let lights = self.lights;
        if let Some(sky) = &lights.sky {
            let w = bsdf_pdf.map_or(1.0, |p| power_heuristic(p, sky.pdf(dir)));
            self.radiance += self.throughput * sky.radiance(dir) * w;
        }
        if let Some((l, pdf)) = lights.sun_along(dir) {
            let w = bsdf_pdf.map_or(1.0, |p| power_heuristic(p, pdf));
            self.radiance += self.throughput * l * w;
        }
    }
}

/// Traces one path from `ray` and returns its sample.
pub fn trace_path(
    scene: &Scene,
    lights: &Lights,
    settings: &TraceSettings,
    ray: &Ray,
    rng: &mut Pcg32,
) -> Sample {
    let mut sample = Sample {
        radiance: [0.0; 3],
        distance: f32::INFINITY,
        virtual_distance: f32::INFINITY,
    };
    let dir = ray.dir.normalize_or_zero();
    if dir == Vec3::ZERO || !dir.is_finite() || !ray.origin.is_finite() {
        return sample;
    }
    let mut ray = Ray::new(ray.origin, dir);
    let mut path = Path {
        scene,
        lights,
        radiance: Vec3::ZERO,
        throughput: Vec3::ONE,
    };
    // `None` while the path has only seen delta lobes since its last light sample.
    let mut prev_pdf: Option<f32> = None;
    // Virtual distance so far, while the path is still looking through flat deltas.
    let mut virtual_so_far = Some(0.0f32);
    for depth in 0..settings.max_depth {
        let Some(hit) = scene.closest_hit(&ray, f32::INFINITY) else {
            path.add_environment(ray.dir, prev_pdf);
            break;
        };
        if depth == 0 {
            sample.distance = hit.t;
        }
        let sp = scene.surface(&hit);
        let material = &scene.materials[sp.material as usize];
        let params = material.params(&scene.textures, sp.uv);
        let wo = -ray.dir;
        let ng = sp.geometric_normal;
        let bsdf = Bsdf::new(&params);

        if let Some(v) = virtual_so_far {
            let v = v + hit.t;
            if bsdf.is_pure_delta() && sp.flat {
                virtual_so_far = Some(v);
            } else {
                sample.virtual_distance = v;
                virtual_so_far = None;
            }
        }

        // Emission, weighted against the light sampling that could have chosen it.
        if params.emission.max_element() > 0.0 && (ng.dot(wo) > 0.0 || material.double_sided) {
            let w = prev_pdf.map_or(1.0, |p| {
                power_heuristic(p, lights.area_pdf(scene, &hit, ng, ray.dir))
            });
            path.radiance += path.throughput * params.emission * w;
        }

        let frame = Frame::new(sp.shading_normal);
        if bsdf.has_non_delta() && !lights.is_empty() {
            path.sample_lights(rng, &frame, &bsdf, wo, sp.position, ng);
        }

        let uc: f32 = rng.random();
        let Some(bs) = bsdf.sample(frame.to_local(wo), uc, u2(rng)) else {
            break;
        };
        let wi = frame.to_world(bs.wi).normalize();
        if !bsdf.transmits() && ng.dot(wi) * ng.dot(wo) <= 0.0 {
            break; // a shading normal sent the path through an opaque surface
        }
        path.throughput *= bs.weight;
        if !path.throughput.is_finite() || path.throughput.max_element() <= 0.0 {
            break;
        }
        prev_pdf = (!bs.delta).then_some(bs.pdf);

        if depth + 1 >= settings.roulette_depth {
            let p_continue = path.throughput.max_element().min(0.95);
            if rng.random::<f32>() >= p_continue {
                break;
            }
            path.throughput /= p_continue;
        }
        ray = Ray::new(offset(sp.position, ng, wi), wi);
    }
    let l = path.radiance;
    if l.is_finite() {
        sample.radiance = l.max(Vec3::ZERO).to_array();
    }
    sample
}
