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
//! `docs/vlf-direct.md`, "Exact samples").
//!
//! Moving objects are not seen by the bounce (it reads the static field); where the eye
//! sees one, the sample is what the wall draws there (its probe's light and its direct
//! light), and such pixels show the lookup alone ([`crate::Lookup::samples`]).

use glam::{Vec2, Vec3};
use holocave_scene::Ray;
use holocave_tracer::frame::Frame;
use rand::{Rng, SeedableRng, rngs::SmallRng};
use rayon::prelude::*;

use crate::pixel_direct::PixelDirect;
use crate::view::Visibility;

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
}

/// A gather sample of `ray`: `direct` gives the next-event part at both vertices,
/// `indirect` is the light field's remainder ([`crate::State::indirect_values`]); `seed`
/// picks the sample.
pub fn gather(
    vis: &Visibility,
    direct: &PixelDirect,
    indirect: &[[f32; 3]],
    ray: Ray,
    seed: u64,
) -> Gathered {
    let (lookup, point, first) = vis.lookup_point_and_hit(ray);
    let mut g = Gathered {
        radiance: Vec3::from(lookup.emitted),
        distance: first.map_or(f32::INFINITY, |h| h.t),
        material: None,
        object: None,
        object_beyond: false,
    };
    let mut rng = SmallRng::seed_from_u64(seed);
    vis.with_placed(|placed| {
        g.material = first.map(|h| placed.surface(&h).material);
        g.object = first.and_then(|h| placed.object_of(h.triangle));
        g.object_beyond = g.object.is_none() && lookup.object != 0;
        let Some(p) = point else {
            return;
        };
        // The sky's direct light at x (when the estimates take it) comes along the bounce
        // below, as the sky seen by an escaping ray; a moving object's lookup holds it
        // already (its probe's, with the rest of its indirect light).
        let e = direct.estimate(placed, &p, rng.random(), 0);
        g.radiance += e.radiance - e.sky;
        if placed.object_of(p.triangle).is_some() {
            return;
        }
        g.radiance += direct.via_mirror(placed, &p, rng.random());
        let frame = Frame::new(p.shading_normal);
        let (uc, u) = (rng.random(), Vec2::new(rng.random(), rng.random()));
        let Some(s) = p.bsdf.sample(frame.to_local(p.wo), uc, u) else {
            return;
        };
        let wi = frame.to_world(s.wi).normalize();
        // An opaque surface reflects only to the side it is seen from.
        if !p.bsdf.transmits() && p.normal.dot(wi) * p.normal.dot(p.wo) <= 0.0 {
            return;
        }
        if !s.weight.is_finite() || s.weight.max_element() <= 0.0 {
            return;
        }
        let leaving = Ray::leaving(p.position, p.normal, wi);
        let a = vis.arriving(leaving.origin, wi, indirect);
        let mut arriving = a.radiance + direct.tile_albedo(&a.lookup, indirect);
        if let Some(over) = &a.over_mirror
            && !s.delta
        {
            arriving -= (1.0 - direct.mirror_weight(s.pdf, over)) * over.emitted;
        }
        let at_y = a.point.map_or(Vec3::ZERO, |q| {
            direct.estimate(placed, &q, rng.random(), 0).radiance
        });
        g.radiance += p.weight * s.weight * (arriving + at_y);
    });
    if !g.radiance.is_finite() {
        g.radiance = Vec3::ZERO;
    }
    g
}

/// One gather sample of each ray, on all cores; ray `i` takes the sample `seed` and `i`
/// pick, so a batch is the same on any machine.
pub fn gather_all(
    vis: &Visibility,
    direct: &PixelDirect,
    indirect: &[[f32; 3]],
    rays: &[Ray],
    seed: u64,
) -> Vec<Gathered> {
    rays.par_iter()
        .enumerate()
        .map(|(i, &ray)| {
            let s = seed ^ (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
            gather(vis, direct, indirect, ray, s)
        })
        .collect()
}
