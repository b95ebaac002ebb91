//! The path tracer: one path per ray, next-event estimation (direct, and through flat
//! mirrors) with multiple importance sampling (power heuristic) against BSDF sampling,
//! Russian roulette, and the virtual distance through flat mirrors and flat glass.

use glam::{Vec2, Vec3};
use holocave_scene::{Hit, Ray, Scene, leave_surface, surface_epsilon};
use rand::Rng;
use rand_pcg::Pcg32;

use crate::bsdf::Bsdf;
use crate::frame::Frame;
use crate::lights::{LightSample, Lights};
use crate::mirrors::ViaMirror;
use crate::sampling::{is_positive_finite, power_heuristic};
use crate::{TraceSettings, TracedRay};

/// The shadow ray from surface point `p` (face normal `ng`) to `target`, and how far it
/// may go before it reaches the target; `None` when there is no such segment (the target
/// is on the point). The ray starts just off the surface and is aimed at the target itself
/// from there, stopping short of it: keeping the direction from `p` would run parallel to
/// the true segment and cross a light's plane `eps / cos θl` early, so that at grazing
/// angles (cos θl < 1/2) the light occluded itself.
fn segment_ray(p: Vec3, ng: Vec3, target: Vec3) -> Option<(Ray, f32)> {
    let origin = leave_surface(p, ng, target - p);
    let d = target - origin;
    let len = d.length();
    if !is_positive_finite(len) {
        return None;
    }
    let margin = surface_epsilon(target);
    Some((Ray::new(origin, d / len), (len - margin).max(0.0)))
}

/// Whether nothing blocks the segment from surface point `p` (face normal `ng`) to
/// `target` (see [`segment_ray`]).
pub(crate) fn segment_clear(scene: &Scene, p: Vec3, ng: Vec3, target: Vec3) -> bool {
    segment_ray(p, ng, target).is_some_and(|(ray, tmax)| !scene.occluded(&ray, tmax))
}

/// The shadow ray of light sample `ls` from surface point `p` (face normal `ng`) and its
/// length: the segment to the light point, or for the sun and sky the whole ray. `None`:
/// blocked by construction (the light point lies on `p`).
pub fn shadow_ray(ls: &LightSample, p: Vec3, ng: Vec3) -> Option<(Ray, f32)> {
    if ls.dist.is_finite() {
        segment_ray(p, ng, p + ls.wi * ls.dist)
    } else {
        Some((Ray::leaving(p, ng, ls.wi), f32::INFINITY))
    }
}

/// Whether nothing blocks light sample `ls` from surface point `p` (face normal `ng`).
pub fn light_unblocked(scene: &Scene, ls: &LightSample, p: Vec3, ng: Vec3) -> bool {
    shadow_ray(ls, p, ng).is_some_and(|(ray, tmax)| !scene.occluded(&ray, tmax))
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
        if !light_unblocked(self.scene, &ls, p, ng) {
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
        if lights.has_mirrors() {
            let (um, uc) = (rng.random(), rng.random());
            if let Some(ls) = lights.sample_via_mirror(self.scene, p, um, uc, u2(rng)) {
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
        if lights.sky.is_some()
            && let Some(ls) = lights.sample_sky(u2(rng))
        {
            self.add_light(ls, frame, bsdf, wo, p, ng);
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

/// Where a path begins: either its sample is already known (a ray that cannot be traced,
/// or one that passes the scene by and sees only the sky), or the ray to trace, moved up
/// to the scene, and the distance that move skipped.
pub enum PathStart {
    Done(TracedRay),
    Trace { ray: Ray, skipped: f64 },
}

/// The start of the path along `ray` (no random numbers are drawn here, and no ray is
/// traced: the first hit may be found for many paths at once).
pub fn start_path(scene: &Scene, lights: &Lights, ray: &Ray) -> PathStart {
    let sample = TracedRay::NONE;
    // A unit direction is used exactly as given: renormalising it would turn it by up to
    // an ulp (6e-8 rad), which shifts the line by 0.6 mm 10 km away. Others are scaled
    // by their largest component before normalising, so that a finite direction whose
    // squared length under- or overflows (components below ~1e-19 or above ~1e19) still
    // has a direction. Zero, NaN and infinite directions give an empty sample.
    let scale = ray.dir.abs().max_element();
    if !is_positive_finite(scale) || !ray.dir.is_finite() || !ray.origin.is_finite() {
        return PathStart::Done(sample);
    }
    let dir = if (ray.dir.length_squared() - 1.0).abs() <= 4.0 * f32::EPSILON {
        ray.dir
    } else {
        (ray.dir / scale).normalize_or_zero()
    };
    if dir == Vec3::ZERO || !dir.is_finite() {
        return PathStart::Done(sample);
    }
    let (lo, hi) = scene.bounds();
    match enter_bounds(ray.origin, dir, lo, hi) {
        Some((origin, skipped)) => PathStart::Trace {
            ray: Ray::new(origin, dir),
            skipped,
        },
        None => {
            // The ray passes the scene by: only the sky and sun can be seen along it.
            let mut path = Path {
                scene,
                lights,
                radiance: Vec3::ZERO,
                throughput: Vec3::ONE,
            };
            path.add_environment(dir, None);
            PathStart::Done(TracedRay {
                radiance: finish(path.radiance),
                ..sample
            })
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
) -> TracedRay {
    match start_path(scene, lights, ray) {
        PathStart::Done(sample) => sample,
        PathStart::Trace { ray, skipped } => {
            let first = scene.closest_hit(&ray, f32::INFINITY);
            finish_path(scene, lights, settings, ray, skipped, first, rng)
        }
    }
}

/// The rest of a path that [`start_path`] began, given what its ray hits first.
pub fn finish_path(
    scene: &Scene,
    lights: &Lights,
    settings: &TraceSettings,
    mut ray: Ray,
    skipped: f64,
    first_hit: Option<Hit>,
    rng: &mut Pcg32,
) -> TracedRay {
    let mut sample = TracedRay::NONE;
    let mut path = Path {
        scene,
        lights,
        radiance: Vec3::ZERO,
        throughput: Vec3::ONE,
    };
    // `None` while the path has only seen delta lobes since its last light sample.
    let mut prev_pdf: Option<f32> = None;
    // Set while the path has gone from a non-delta vertex over one flat mirror, the one
    // delta path that light sampling through mirrors also finds.
    let mut via_mirror: Option<ViaMirror> = None;
    // Virtual distance so far, while the path is still looking through flat deltas.
    let mut virtual_so_far = Some(0.0f32);
    let mut first_hit = Some(first_hit);
    for depth in 0..settings.max_depth {
        let hit = match first_hit.take() {
            Some(first) => first,
            None => scene.closest_hit(&ray, f32::INFINITY),
        };
        let Some(hit) = hit else {
            path.add_environment(ray.dir, prev_pdf);
            break;
        };
        // Distances along the camera ray count from its own origin.
        let sp = scene.surface(&hit);
        let t = if depth == 0 {
            sample.distance = (skipped + f64::from(hit.t)) as f32;
            sample.material = Some(sp.material);
            sample.distance
        } else {
            hit.t
        };
        let material = &scene.materials[sp.material as usize];
        let params = material.params(&scene.textures, sp.uv);
        let wo = -ray.dir;
        let ng = sp.geometric_normal;
        let bsdf = Bsdf::new(&params);

        if let Some(v) = virtual_so_far {
            virtual_so_far = through_flat_delta(v + t, &bsdf, sp.flat, &mut sample);
        }

        // Emission, weighted against the light sampling that could have chosen it.
        if params.emission.max_element() > 0.0 && (ng.dot(wo) > 0.0 || material.double_sided) {
            let w = emission_weight(lights, (prev_pdf, via_mirror), &hit, &ray, ng);
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
        via_mirror = match (bs.delta, prev_pdf) {
            (true, Some(bsdf_pdf)) => lights.mirror_index(hit.triangle).map(|mirror| ViaMirror {
                bsdf_pdf,
                mirror,
                distance: hit.t,
            }),
            _ => None,
        };
        prev_pdf = (!bs.delta).then_some(bs.pdf);

        if depth + 1 >= settings.roulette_depth {
            let p_continue = path.throughput.max_element().min(0.95);
            if rng.random::<f32>() >= p_continue {
                break;
            }
            path.throughput /= p_continue;
        }
        ray = Ray::leaving(sp.position, ng, wi);
    }
    sample.radiance = finish(path.radiance);
    sample
}

/// The virtual distance `v` so far, after a surface: still growing past a flat mirror or
/// pane (`Some`), else ended there and kept as `sample`'s virtual distance (`None`).
#[inline]
fn through_flat_delta(v: f32, bsdf: &Bsdf, flat: bool, sample: &mut TracedRay) -> Option<f32> {
    if bsdf.is_pure_delta() && flat {
        return Some(v);
    }
    sample.virtual_distance = v;
    None
}

/// The MIS weight of emission met at `hit` along `ray` against the light sampling that
/// could have chosen it: directly after a non-delta bounce of density `prev_pdf`, or
/// through one flat mirror (`via`); 1 where no light sampling could have.
#[inline]
fn emission_weight(
    lights: &Lights,
    (prev_pdf, via): (Option<f32>, Option<ViaMirror>),
    hit: &Hit,
    ray: &Ray,
    ng: Vec3,
) -> f32 {
    match (prev_pdf, via) {
        (Some(p), _) => power_heuristic(p, lights.area_pdf(hit, ray.origin, ng, ray.dir)),
        (None, Some(via)) => power_heuristic(
            via.bsdf_pdf,
            lights.mirror_pdf(&via, hit.triangle, ng, ray.dir, hit.t),
        ),
        (None, None) => 1.0,
    }
}

/// The radiance reported for a path: never negative, and zero rather than NaN or Inf.
fn finish(l: Vec3) -> [f32; 3] {
    if l.is_finite() {
        l.max(Vec3::ZERO).to_array()
    } else {
        [0.0; 3]
    }
}

/// Where a ray enters the scene's bounds (grown by a margin), computed in f64: a ray that
/// starts far away (10 km, say) is moved up to the scene along its exact line, so that
/// intersection is as precise as for a ray starting nearby, instead of working with an
/// origin whose float spacing (1 mm at 1e4 m) shifts the ray sideways and lets it slip
/// past edges. Returns the new origin and the distance skipped (0 and the origin itself
/// when it is inside or within 8 scene sizes of the bounds), or `None` when the ray
/// misses the bounds altogether.
fn enter_bounds(origin: Vec3, dir: Vec3, lo: Vec3, hi: Vec3) -> Option<(Vec3, f64)> {
    // Most rays start inside (every bounce, every eye in a CAVE): kept as they are.
    if origin.cmpge(lo).all() && origin.cmple(hi).all() {
        return Some((origin, 0.0));
    }
    let extent = f64::from((hi - lo).max_element());
    let margin = 1e-3 * (1.0 + extent);
    // An eye outside but near: a test in f32 settles it when the entry is well within the
    // distance that keeps the origin (its rounding, ~1e-7 relative, cannot change that).
    // A ray it finds to miss the grown bounds by rounding alone meets no geometry either
    // way, so keeping it changes only the work, not the sample.
    let keep = 8.0 * (1.0 + extent);
    if dir.cmpne(Vec3::ZERO).all() {
        let (lo32, hi32) = (lo - margin as f32, hi + margin as f32);
        let inv = dir.recip();
        let (ta, tb) = ((lo32 - origin) * inv, (hi32 - origin) * inv);
        let near = ta.min(tb).max_element().max(0.0);
        let far = ta.max(tb).min_element();
        if near.is_finite() && far.is_finite() && f64::from(near) < 0.5 * keep {
            return (near <= far).then_some((origin, 0.0));
        }
    }
    let (o, d) = (origin.as_dvec3(), dir.as_dvec3());
    let (lo, hi) = (lo.as_dvec3() - margin, hi.as_dvec3() + margin);
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for a in 0..3 {
        if d[a] == 0.0 {
            if o[a] < lo[a] || o[a] > hi[a] {
                return None;
            }
            continue;
        }
        let (ta, tb) = ((lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
        t0 = t0.max(ta.min(tb));
        t1 = t1.min(ta.max(tb));
    }
    if t0 > t1 {
        return None;
    }
    // Nearby origins are kept exactly: moving one perturbs its ray by ~1e-7 for no gain.
    if t0 <= 8.0 * (1.0 + extent) {
        return Some((origin, 0.0));
    }
    Some(((o + d * t0).as_vec3(), t0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn far_origins_are_moved_to_the_bounds_on_their_exact_line() {
        let (lo, hi) = (Vec3::splat(-1.0), Vec3::splat(1.0));
        let d = Vec3::new(0.1, 0.2, -1.0).normalize();
        let o = Vec3::new(0.0, 0.0, 0.5) - d * 1e4;
        let (p, t) = enter_bounds(o, d, lo, hi).unwrap();
        // On the line from o along d (in f64), at the grown box's face z = 1.003.
        let exact = o.as_dvec3() + d.as_dvec3() * t;
        assert!((p.as_dvec3() - exact).length() < 1e-6);
        assert!((f64::from(p.z) - 1.003).abs() < 1e-6, "{p}");
        // Nearby and inside origins are left alone; rays missing the box are reported.
        let near = Vec3::new(0.0, 0.0, 3.0);
        assert_eq!(enter_bounds(near, -Vec3::Z, lo, hi), Some((near, 0.0)));
        assert_eq!(
            enter_bounds(Vec3::ZERO, Vec3::X, lo, hi),
            Some((Vec3::ZERO, 0.0))
        );
        assert_eq!(
            enter_bounds(Vec3::new(0.0, 5.0, 1e4), -Vec3::Z, lo, hi),
            None
        );
        assert_eq!(
            enter_bounds(Vec3::new(0.0, 0.0, 1e4), Vec3::Z, lo, hi),
            None
        );
    }

    #[test]
    fn reported_radiance_is_never_negative_or_nan() {
        assert_eq!(finish(Vec3::new(1.0, -0.5, 2.0)), [1.0, 0.0, 2.0]);
        assert_eq!(finish(Vec3::new(1.0, f32::NAN, 2.0)), [0.0; 3]);
        assert_eq!(finish(Vec3::new(f32::INFINITY, 0.0, 0.0)), [0.0; 3]);
    }
}
