//! Exact samples that help: a sample of the light along an eye ray that is exact where
//! exactness is cheap and ends in the light field after one bounce (radiance caching, as
//! in the holodeck paper's "ambient" value or real-time neural radiance caching).
//!
//! For the non-delta point `x` an eye ray sees (through mirrors and glass, as a wall
//! draws it), one sample is
//!
//! ```text
//!   L = E + D̂(x) + f(x, wi) |cos| / p(wi) · ( S(wi) + I(y → x) + D̂(y) )
//! ```
//!
//! with `E` the light the eye sees along the way (emitters, the sky), `D̂` one next-event
//! estimate of the direct light of the sun, punctual lights and emitters
//! ([`PixelDirect::estimate`]: shadow rays and the full BSDF), `wi` drawn from `x`'s BSDF,
//! `y` the static surface it reaches (again through mirrors and glass), `S` the sky along
//! the way and `I` the light field's remainder at `y` ([`crate::State::indirect_values`]:
//! its light without the next-event part). Nothing is counted twice: the lamps and the sun
//! come only by next-event estimation, the sky only along rays, inter-reflected light only
//! from the field.
//!
//! Against a full path this has far less variance (no second random bounce, no caustic
//! fireflies: a path that would find a lamp after a bounce finds it by a shadow ray) and
//! only a small bias: the light field's error at `y`, seen after one bounce (times the
//! albedo and spread over the hemisphere), where a pixel's light-field lookup has its
//! whole error at `x`. The sun patch a surface sees and the light a lamp casts on the
//! walls around are exact in it. What a still view converges to with these samples is
//! therefore not the path tracer's image but this one-bounce image (see
//! `docs/performance/history.md`, "Exact samples").
//!
//! Moving objects are not seen by the bounce (it reads the static field); where the eye
//! sees one, the sample is what the wall draws there (its probe's light and its direct
//! light), and such pixels show the lookup alone ([`crate::Lookup::samples`]).

use glam::{Vec2, Vec3};
use holocave_scene::{Hit, PlacedScene, Ray};
use holocave_tracer::frame::Frame;
use rand::{Rng, SeedableRng, rngs::SmallRng};
use rayon::prelude::*;

use crate::elements::bilinear_cells;
use crate::pixel_direct::{Estimate, PixelDirect, Sampled, ShadowQuery};
use crate::static_rays::{StaticRays, per_group};
use crate::view::Visibility;
use crate::view::{Lookup, ReflectionFrames};

/// One sample along an eye ray.
#[derive(Clone, Copy, Debug)]
pub struct Gathered {
    /// The radiance towards the eye.
    pub radiance: Vec3,
    /// Distance to the ray's first hit (a mirror or glass included: where the sample is
    /// stored); infinite when it escapes.
    pub distance: f32,
    /// The material of that hit; `None` when the ray escapes.
    pub material: Option<u32>,
    /// The moving object of that hit (its index), if it lies on one.
    pub object: Option<usize>,
    /// The ray meets a moving object beyond the mirrors and glass it first hits.
    pub object_beyond: bool,
    /// Where the eye sees a diffuse element of the light field (away from moving
    /// objects): the elements the lookup interpolates there with their weights, and the
    /// irradiance there this sample estimates — the part
    /// the field's remainder holds (after the bounce, and the emitters over a mirror) over
    /// the lookup's weight towards the eye: the quantity the element holds
    /// ([`crate::kept_gathers`]). Where it sees a surface drawn as its mirror, the same
    /// for its Lambertian base's elements, from what the base alone reflects after the
    /// bounce.
    pub kept: Option<([(u32, f32); 4], Vec3)>,
}

/// A sample between its batches of rays: what it has so far, its shadow queries (the
/// next-event estimate's at `x`, then the one over a mirror, then the estimate's at `y`),
/// and its bounce.
struct Pending {
    g: Gathered,
    rng: SmallRng,
    queries: Vec<ShadowQuery>,
    /// Queries of the estimate at `x`, and whether one over a mirror follows them.
    at_x: usize,
    via_mirror: bool,
    bounce: Option<Bounce>,
    /// What arrives at `x` along the bounce, but `y`'s direct light.
    arriving: Vec3,
    /// Of that, the lights seen through mirrors and glass ([`crate::view::Arriving::caustic`]).
    caustic: Vec3,
    /// The walls take the caustics per pixel ([`Visibility::caustic_light`]): what is kept
    /// in the field leaves them out. The sample itself keeps those it finds along its
    /// bounce: its variance is what the light field's prior is measured against
    /// (`docs/performance/history.md`, "Caustics per pixel").
    caustics_per_pixel: bool,
    /// The elements the lookup at `x` interpolates and its weight towards the eye, where
    /// it is a diffuse element's or the Lambertian base's of a surface drawn as its
    /// mirror.
    element: Option<([(u32, f32); 4], Vec3)>,
    /// The element is a mirror-drawn surface's base: only the light its Lambertian base
    /// reflects is kept (the rest is what its lobe mirrors, not the element's).
    base_only: bool,
}

/// The ray leaving `x` that the BSDF drew, and what it carries to the eye.
struct Bounce {
    ray: Ray,
    /// `x`'s weight towards the eye times the BSDF sample's weight.
    throughput: Vec3,
    /// The part of `throughput` that the Lambertian base reflects.
    diffuse: Vec3,
    pdf: f32,
    delta: bool,
}

/// One gather sample of each ray, on all cores, ray `i` taking the sample `seed` and `i`
/// pick (so a batch is the same on any machine): `direct` gives the next-event part at
/// both vertices, `indirect` is the light field's remainder
/// ([`crate::State::indirect_values`]). Their rays against the static scene go to `traced`
/// in three batches — the eye rays' first hits, the bounces', every shadow ray — so the
/// same samples come from the CPU's walk or a GPU's; the moving objects are tested here.
pub fn gather_all(
    vis: &Visibility,
    direct: &PixelDirect,
    indirect: &[[f32; 3]],
    rays: &[Ray],
    seed: u64,
    traced: &dyn StaticRays,
) -> Vec<Gathered> {
    let first = traced.closest_hits(rays);
    let mut pending: Vec<Pending> = (rays.par_iter().zip(first))
        .enumerate()
        .map(|(i, (&ray, hit))| {
            let s = seed ^ (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
            at_eye(vis, direct, ray, hit, SmallRng::seed_from_u64(s))
        })
        .collect();
    let bounces: Vec<Ray> = pending
        .iter()
        .filter_map(|p| p.bounce.as_ref().map(|b| b.ray))
        .collect();
    let mut hits = traced.closest_hits(&bounces).into_iter();
    let reached: Vec<(&mut Pending, Option<Hit>)> = pending
        .iter_mut()
        .filter(|p| p.bounce.is_some())
        .map(|p| (p, hits.next().flatten()))
        .collect();
    reached
        .into_par_iter()
        .for_each(|(p, hit)| along_bounce(vis, direct, indirect, p, hit));
    let groups: Vec<Vec<ShadowQuery>> = pending
        .iter_mut()
        .map(|p| std::mem::take(&mut p.queries))
        .collect();
    let blocked = traced.blocked(&groups);
    let blocked = per_group(&groups, &blocked);
    vis.with_placed(|placed| {
        (pending.into_par_iter().zip(&groups).zip(blocked))
            .map(|((p, queries), blocked)| finish(placed, p, queries, blocked))
            .collect()
    })
}

/// A sample's first part: what the eye ray (first static hit `hit`) sees, the
/// estimate's shadow queries at the point `x` it ends on, the one over a mirror, and the
/// bounce the BSDF draws there.
fn at_eye(
    vis: &Visibility,
    direct: &PixelDirect,
    ray: Ray,
    hit: Option<Hit>,
    rng: SmallRng,
) -> Pending {
    // A gather's eye ray takes a view's first frame's glossy directions.
    let first_frame = ReflectionFrames::still(0);
    let (lookup, point, first) = vis.lookup_point_and_hit(ray, hit, &first_frame);
    let element = diffuse_element(&lookup);
    let base = element
        .is_none()
        .then(|| vis.mirrored_base(&ray, first))
        .flatten();
    let mut p = Pending {
        g: Gathered {
            radiance: Vec3::from(lookup.emitted),
            distance: first.map_or(f32::INFINITY, |h| h.t),
            material: None,
            object: None,
            object_beyond: false,
            kept: None,
        },
        rng,
        queries: Vec::new(),
        at_x: 0,
        via_mirror: false,
        bounce: None,
        arriving: Vec3::ZERO,
        caustic: Vec3::ZERO,
        caustics_per_pixel: vis.caustics_per_pixel(),
        element: element.or(base),
        base_only: base.is_some(),
    };
    vis.with_placed(|placed| {
        p.g.material = first.map(|h| placed.surface(&h).material);
        p.g.object = first.and_then(|h| placed.object_of(h.triangle));
        p.g.object_beyond = p.g.object.is_none() && lookup.object != 0;
        let Some(x) = point else {
            return;
        };
        // The sky's direct light at x (when the estimates take it) comes along the bounce
        // below, as the sky seen by an escaping ray; a moving object's lookup holds it
        // already (its probe's, with the rest of its indirect light).
        direct.queries(&x, p.rng.random(), 0, &mut p.queries);
        p.at_x = p.queries.len();
        if placed.object_of(x.triangle).is_some() {
            return;
        }
        if let Some(q) = direct.via_mirror(&x, p.rng.random()) {
            p.queries.push(q);
            p.via_mirror = true;
        }
        let frame = Frame::new(x.shading_normal);
        let r = &mut p.rng;
        let (uc, u) = (r.random(), Vec2::new(r.random(), r.random()));
        let Some(s) = x.bsdf.sample(frame.to_local(x.wo), uc, u) else {
            return;
        };
        let wo = frame.to_local(x.wo);
        let wi = frame.to_world(s.wi).normalize();
        // An opaque surface reflects only to the side it is seen from.
        if !x.bsdf.transmits() && x.normal.dot(wi) * x.normal.dot(x.wo) <= 0.0 {
            return;
        }
        if !s.weight.is_finite() || s.weight.max_element() <= 0.0 {
            return;
        }
        p.bounce = Some(Bounce {
            ray: Ray::leaving(x.position, x.normal, wi),
            throughput: x.weight * s.weight,
            diffuse: x.weight * x.bsdf.eval_diffuse(wo, s.wi) * s.wi.z.abs() / s.pdf,
            pdf: s.pdf,
            delta: s.delta,
        });
    });
    p
}

/// A sample's second part: what arrives at `x` along its bounce (first static hit `hit`)
/// from the light field and the sky, and the estimate's shadow queries at the static
/// point `y` it reaches.
fn along_bounce(
    vis: &Visibility,
    direct: &PixelDirect,
    indirect: &[[f32; 3]],
    p: &mut Pending,
    hit: Option<Hit>,
) {
    let Some(b) = &p.bounce else { return };
    let a = vis.arriving_from(b.ray, hit, indirect);
    p.arriving = a.radiance + direct.tile_albedo(&a.lookup, indirect);
    p.caustic = a.caustic;
    if let Some(over) = &a.over_mirror
        && !b.delta
    {
        let by_next_event = (1.0 - direct.mirror_weight(b.pdf, over)) * over.emitted;
        p.arriving -= by_next_event;
        p.caustic -= by_next_event;
    }
    if let Some(y) = a.point {
        p.arriving += vis.caustic_light(&a.lookup, &y, None);
        direct.queries(&y, p.rng.random(), 0, &mut p.queries);
    }
}

/// The sample, given whether the static scene blocks each of its shadow queries
/// (`blocked`, in order), the moving objects where `placed` puts them.
fn finish(placed: &PlacedScene, p: Pending, queries: &[ShadowQuery], blocked: &[bool]) -> Gathered {
    let mut answers = queries
        .iter()
        .zip(blocked)
        .map(|(q, &b)| (q.light, PixelDirect::resolve(placed, q, b)));
    let mut g = p.g;
    let mut e = Estimate::default();
    // The sky at `x` comes along the bounce, reflected by the surface's own lobe: neither
    // the sky's samples nor its sharpened reflection (what that lobe reflects beyond the
    // tile's) are taken here as well.
    for (light, a) in answers.by_ref().take(p.at_x) {
        if light != Sampled::Sharpening {
            e += a;
        }
    }
    g.radiance += e.radiance - e.sky;
    // What the light field's remainder holds at `x`: the light after the bounce, and the
    // emitters' light over a mirror (the walls' direct light per pixel leaves it to the
    // field); of each, the caustics (the emitters over the mirror, and the lights through
    // mirrors and glass along the bounce).
    let (mut remainder, mut caustic) = (Vec3::ZERO, Vec3::ZERO);
    if p.via_mirror
        && let Some((_, v)) = answers.next()
    {
        remainder += v.radiance;
        caustic += v.radiance;
    }
    // What the Lambertian base alone reflects of the light along the bounce (a delta
    // bounce's share is none of it).
    let (mut base, mut base_caustic) = (Vec3::ZERO, Vec3::ZERO);
    if let Some(b) = &p.bounce {
        let at_y = answers.fold(Vec3::ZERO, |sum, (_, a)| sum + a.radiance);
        remainder += b.throughput * (p.arriving + at_y);
        caustic += b.throughput * p.caustic;
        if !b.delta {
            base = b.diffuse * (p.arriving + at_y);
            base_caustic = b.diffuse * p.caustic;
        }
    }
    g.radiance += remainder;
    if !g.radiance.is_finite() {
        g.radiance = Vec3::ZERO;
    }
    // Where the walls take the caustics per pixel, the field's remainder holds none.
    if p.caustics_per_pixel {
        remainder -= caustic;
        base -= base_caustic;
    }
    let kept = if p.base_only { base } else { remainder };
    g.kept = p
        .element
        .map(|(e, weight)| (e, kept / weight))
        .filter(|(_, estimate)| estimate.is_finite());
    g
}

/// The elements a lookup interpolates and its weight towards the eye, where the lookup
/// is a diffuse element's away from moving objects (not a tile, a surface drawn as a
/// mirror or an object) and weighs every channel.
fn diffuse_element(l: &Lookup) -> Option<([(u32, f32); 4], Vec3)> {
    let weight = Vec3::from(l.weight);
    let plain = l.base != u32::MAX && l.tile == u32::MAX && l.object == 0 && l.samples > 0.0;
    (plain && weight.min_element() > 0.0).then(|| (bilinear_cells(l.base, l.res, l.u, l.v), weight))
}
