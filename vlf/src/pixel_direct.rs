//! Direct light per pixel: the light of the sun (a disc of its angular size), punctual
//! lights and emissive triangles reaching the point a pixel sees, by next-event estimation
//! with shadow rays against the scene and the point's full BSDF (the tracer's
//! [`Bsdf::eval`] and [`Lights`] sampling). Exactly the lights the bake takes by
//! next-event estimation (`direct`): the bake keeps that part apart
//! ([`crate::State::direct`]) and a view that computes it here draws the light field's
//! remainder ([`crate::State::indirect_values`]), so nothing is counted twice.
//!
//! **Shadow rays.** Each estimate takes one sample of each kind of light the scene has:
//! one point on the emissive triangles (if any), every punctual light, one direction in
//! the sun's disc (if any) — `1 + P + 1` shadow rays at most ([`PixelDirect::shadow_rays`]).
//! One is enough for what must be exact at once: a punctual light has no variance at all,
//! and wherever the whole sun disc is seen (the lit patch) or none of it (the umbra) any
//! direction in the disc gives the exact answer (its radiance times its solid angle times
//! a cosine that varies by `1 − cos r ≈ 1e-5` across the disc), so the patch and its
//! shadow are exact from the first frame. What is left stochastic — the penumbrae (a band
//! `2 d tan r` wide, 9 mm behind an edge 1 m away) and area lamps — is averaged per
//! surface point over frames ([`Accumulator`]): a still view converges, and a moving eye
//! carries each mean over to the pixel that sees its point next, while that point stays
//! within a pixel's footprint of where the mean began ([`Accumulator::reproject`]). A pixel takes
//! one estimate a frame, and two on the frame it comes to a new point when the scene
//! has area lamps ([`PixelDirect::first_estimates`]: one sample of a lamp is visibly
//! noisy). More per frame would lower that variance in proportion to the shadow rays,
//! which already cost as much as the visibility itself (measured on two cores: the
//! room's 1024 × 768 view, 0.61 s of visibility and lookups, 0.64 s more for its two
//! shadow rays per pixel); frames are cheaper.
//!
//! **Sample sequences.** A pixel's `n`-th estimate takes its sun direction from the 2-D
//! and its area-light point from the 3-D "R" low-discrepancy sequence (Roberts' additive
//! recurrence on the plastic number and its 3-D analogue), shifted per pixel by a hash
//! (Cranley–Patterson rotation): successive frames fill the disc and the lamps evenly, so
//! a penumbra's error falls nearly as `1/n` rather than `1/√n`, and neighbouring pixels'
//! errors are not correlated.
//!
//! **Moving objects.** Shadow rays see the moving objects where the frame places them
//! (static BVH first, then each object's), so an object casts exact shadows on the room
//! and on itself, and the room shadows it. An estimate says whether an object blocked one
//! of its rays: there the static caches' samples (which never see objects) are wrong.

use glam::{Vec2, Vec3};
use holocave_cave::WallView;
use holocave_scene::{PlacedScene, Ray, Scene};
use holocave_tracer::bsdf::Bsdf;
use holocave_tracer::frame::Frame;
use holocave_tracer::fresnel;
use holocave_tracer::integrator::shadow_ray;
use holocave_tracer::lights::{LightSample, Lights};
use holocave_tracer::microfacet::Ggx;
use holocave_tracer::mirrors::ViaMirror;
use holocave_tracer::sampling::power_heuristic;
use rayon::prelude::*;
use std::sync::Arc;

use crate::footprint::Screen;
use crate::sequence::{R2, R3, R4, r_sequence};
use crate::settling::{Settling, Spread, luminance};
use crate::static_rays::{StaticRays, per_group};
use crate::tile_albedo::TileAlbedo;
use crate::view::{Lookup, OverMirror};

/// The non-delta surface a pixel sees, as the direct pass needs it.
#[derive(Clone, Copy, Debug)]
pub struct DirectPoint {
    pub triangle: u32,
    pub position: Vec3,
    /// Unit face normal.
    pub normal: Vec3,
    pub shading_normal: Vec3,
    /// Unit direction towards the eye (or the delta surface the eye sees it through).
    pub wo: Vec3,
    pub bsdf: Bsdf,
    /// What the delta surfaces between the eye and the point let through.
    pub weight: Vec3,
    /// Where the lookup reads an element, or on a moving object: the surface's
    /// directional albedo towards `wo` ([`crate::surface::albedo_towards`]), by which
    /// (over π, and times `weight`) the element's irradiance, or what the object's pixel
    /// gathers ([`crate::object_gather`]), reaches the eye; zero elsewhere.
    pub albedo: Vec3,
    /// The light of surfaces that the lookup's emitted light holds (not glow:
    /// [`crate::glow_edges`] leaves it to the surface part): those glass's weaker branches
    /// on the way end on, and the room a widened tile's own lobe reflects beyond the tile
    /// ([`crate::view::Visibility::sharpened_reflection`]).
    pub surfaces: Vec3,
    /// What the lookup's emitted light holds of a glossy lobe's reflection drawn from a
    /// few of its directions ([`crate::view::ReflectionFrames`]), where it was drawn: a
    /// still view's frames take other directions, and a pixel shows the mean of its
    /// frames'.
    pub reflected: Option<Vec3>,
    /// Where the pixel's estimates are taken: moving through the pixel across its width
    /// and down its height moves the point along these on its plane
    /// ([`crate::footprint::pixel_span`]). Each estimate takes its own place in the pixel
    /// ([`PixelDirect::within_pixel`]), so that a still pixel's mean is the mean over its
    /// patch, as the path tracer's: a shadow's edge through the pixel shows as the part of
    /// it that is lit (in motion the [`Accumulator`] takes them at `position`). Zero where
    /// the point is seen through a mirror or glass, or is a moving object's: its
    /// estimates are all taken at `position`.
    pub span: [Vec3; 2],
    /// Its indirect light is gathered per pixel ([`crate::object_gather`]): on a moving
    /// object all of it; on the static scene where an object takes much of the point's
    /// hemisphere (the field, baked without it, is wrong there) what the objects change
    /// of the field's part the lookup shows.
    pub gathered: bool,
}

/// The per-pixel direct light of one scene.
pub struct PixelDirect {
    scene: Arc<Scene>,
    lights: Lights,
    /// The sky is sampled too ([`PixelDirect::with_sky`]).
    sky: bool,
    /// The lobe the light field's tiles widen narrower ones to, and per triangle whether
    /// its sky reflections are sharpened ([`PixelDirect::with_sharp_sky_reflections`];
    /// empty: none).
    widened: Ggx,
    sharpened: Vec<bool>,
    /// What the tiles' bins make of an even light, put right ([`Self::with_tile_albedo`]).
    tile_albedo: TileAlbedo,
}

/// Samples of the sun's disc in each estimate a pixel takes at a new point. A shadow cast
/// from far (a window's blinds on the breakfast room's wall, 2–3 m away) is penumbra
/// across, narrower than its penumbrae: one sample a pixel drew its stripes as dots, lit
/// or not, at the first frame; with two estimates of four each a new point's stripes are
/// eight samples deep. The extra rays are paid only where a pixel starts over.
pub const FIRST_SUN_SAMPLES: u64 = 4;

/// Samples of the area lamps in each estimate a pixel takes at a new point: as the sun's,
/// so that a penumbra is eight samples deep from the first frame of a point.
pub const FIRST_AREA_SAMPLES: u64 = 4;

/// Pairs of samples of the sky's sharpened reflection (one from the true lobe, one from
/// the widened one) in each estimate a pixel takes at a new point. One pair a pixel, a
/// signed difference of two lobes, speckled a varnished floor dark and light where a
/// window is reflected in it at the first frame; four make a new point's reflection
/// four pairs deep, paid only where a pixel starts over, and only on sharpened lobes.
pub const FIRST_SHARPENING_PAIRS: u64 = 4;

/// The barycentrics `(u, v)` of `x`, a point of the plane of triangle `a b c`, where it
/// lies on the triangle (`x = a + u (b − a) + v (c − a)`, as a hit's); `None` where not.
fn barycentrics_on(x: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Option<[f32; 2]> {
    let (e1, e2, w) = (b - a, c - a, x - a);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (dw1, dw2) = (w.dot(e1), w.dot(e2));
    let det = d11 * d22 - d12 * d12;
    let u = (d22 * dw1 - d12 * dw2) / det;
    let v = (d11 * dw2 - d12 * dw1) / det;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0).then_some([u, v])
}

/// Whether light arriving along `wi` reaches the viewer from `p`: opaque surfaces only
/// receive light on the side they are seen from.
fn receives(p: &DirectPoint, wi: Vec3) -> bool {
    p.bsdf.transmits() || p.normal.dot(wi) * p.normal.dot(p.wo) > 0.0
}

/// A direction `wi` drawn with density `pdf` towards the sky (a shadow ray to infinity).
fn towards_sky(wi: Vec3, pdf: f32) -> LightSample {
    LightSample {
        wi,
        dist: f32::INFINITY,
        contribution: Vec3::ZERO,
        pdf,
    }
}

/// The shadow query of light sample `ls` at `p` bringing `radiance` if unblocked (signed:
/// a sharpening sample may take light off); `None` when it brings nothing.
fn shadow_query(
    p: &DirectPoint,
    ls: &LightSample,
    radiance: Vec3,
    light: Sampled,
) -> Option<ShadowQuery> {
    if radiance.abs().max_element() <= 0.0 || !radiance.is_finite() {
        return None;
    }
    let (ray, tmax) = shadow_ray(ls, p.position, p.normal)?;
    Some(ShadowQuery {
        ray,
        tmax,
        radiance,
        light,
        aim: Aim {
            dir: ls.wi,
            dist: ls.dist,
        },
    })
}

impl PixelDirect {
    pub fn new(scene: Arc<Scene>) -> Self {
        let lights = Lights::new(&scene);
        PixelDirect {
            scene,
            lights,
            sky: false,
            widened: Ggx { alpha: 1.0 },
            sharpened: Vec::new(),
            tile_albedo: TileAlbedo::default(),
        }
    }

    /// Also the sky's direct light, by one sample of the sky's own distribution (the
    /// tracer's [`Lights::sample_sky`]) and one of the BSDF per estimate, combined by
    /// multiple importance sampling, each with its shadow ray: for a view that draws the
    /// light field less the sky's first arrival as well
    /// ([`crate::State::indirect_values_without_sky`]). The sky is as large as the
    /// sphere, so unlike the sun's disc an estimate is far from exact: through a window
    /// most samples are blocked, and a still view's mean converges as `1/√n` over frames.
    pub fn with_sky(mut self, on: bool) -> Self {
        self.sky = on && self.lights.sky.is_some();
        self
    }

    /// Whether the sky is sampled too ([`Self::with_sky`]).
    pub fn samples_sky(&self) -> bool {
        self.sky
    }

    /// Also, on the triangles marked in `widened` (whose light-field tiles widen a glossy
    /// lobe narrower than GGX `alpha`, the least a tile resolves, to it), the difference
    /// between the sky the surface reflects and the sky its widened lobe reflects (see
    /// [`Self::sharpening_queries`]): added to the field's sky, the reflection of a
    /// window is as sharp as the surface's. An element without a tile is drawn diffuse,
    /// with no widened lobe to correct, and is left as it is. Not with
    /// [`Self::with_sky`], which takes the whole sky per pixel.
    pub fn with_sharp_sky_reflections(mut self, alpha: f32, widened: Vec<bool>) -> Self {
        if self.lights.sky.is_some() && widened.contains(&true) {
            self.widened = Ggx { alpha };
            self.sharpened = widened;
        }
        self
    }

    /// Also, where a pixel sees a tile, the surface's albedo at the pixel's angle in place
    /// of what the tile's bins make of an even light ([`TileAlbedo`], [`Self::tile_albedo`]).
    pub fn with_tile_albedo(mut self, tile_albedo: TileAlbedo) -> Self {
        self.tile_albedo = tile_albedo;
        self
    }

    /// What lookup `l` adds to the light field's `values` (the lookups'), besides the
    /// estimates: what its tile's bins miss of the surface's albedo ([`TileAlbedo::added`]).
    pub fn tile_albedo(&self, l: &Lookup, values: &[[f32; 3]]) -> Vec3 {
        self.tile_albedo.added(l, values)
    }

    /// Whether the sky's reflection at `p` is sharpened.
    fn sharpens(&self, p: &DirectPoint) -> bool {
        !self.sky
            && self
                .sharpened
                .get(p.triangle as usize)
                .copied()
                .unwrap_or(false)
    }

    /// Where the sky's reflection on triangle `triangle` is sharpened: the GGX `alpha` of
    /// the widened lobe its estimates sample about the mirror direction; `None` where it
    /// is not.
    pub fn sharpened_lobe(&self, triangle: u32) -> Option<f32> {
        let on = !self.sky && self.sharpened.get(triangle as usize) == Some(&true);
        on.then_some(self.widened.alpha)
    }

    /// Whether the scene has any light this pass computes (emissive triangles, punctual
    /// lights, the sun, and the sky when asked).
    pub fn is_empty(&self) -> bool {
        !self.lights.has_area()
            && self.lights.punctual.is_empty()
            && self.lights.sun.is_none()
            && !self.sky
            && self.sharpened.is_empty()
    }

    /// Estimates a pixel takes on the frame it starts over at a new point: 2 when the
    /// scene has emissive triangles, else 1 (the sun and punctual lights are exact in
    /// one, but for the penumbrae). One sample of an area lamp per pixel is visibly noisy:
    /// the Cornell box's first frame under the render cache (64², `render-node`'s
    /// `vlf_base` test) was at relative MSE 0.0216 with one estimate and 0.0158 with four
    /// (the light field's own part ≈ 0.014; the lamp's noise 0.008 with one), 0.0175
    /// with two. In motion every pixel starts over every frame, and four estimates made
    /// `sim`'s nodes (the room: a lamp and the sun, two shadow rays each) too slow to
    /// draw every frame on a shared two-core machine; two is the compromise.
    pub fn first_estimates(&self) -> u32 {
        if self.lights.has_area() || self.sky {
            2
        } else {
            1
        }
    }

    /// The samples of a light in the `n`-th estimate: their first index in the pixel's
    /// sequence and how many. Each of the estimates a pixel takes at a new point
    /// ([`Self::first_estimates`]) takes `at_first` ([`FIRST_SUN_SAMPLES`] of the sun's
    /// disc, [`FIRST_SHARPENING_PAIRS`] of the sky's sharpened reflection), every later
    /// one a single sample, the sequence going on where they left it.
    fn samples_of(&self, n: u64, at_first: u64) -> (u64, u64) {
        let first = u64::from(self.first_estimates());
        if n < first {
            (n * at_first, at_first)
        } else {
            (first * at_first + (n - first), 1)
        }
    }

    /// Shadow rays per estimate after a pixel's first frame at a point (at most: a sample
    /// facing away from the point needs none); the first estimates take
    /// [`FIRST_SUN_SAMPLES`] − 1 more for the sun and, on a sharpened lobe,
    /// [`FIRST_SHARPENING_PAIRS`] − 1 more pairs for the sky's reflection.
    pub fn shadow_rays(&self) -> u32 {
        u32::from(self.lights.has_area())
            + self.lights.punctual.len() as u32
            + u32::from(self.lights.sun.is_some())
            + 2 * u32::from(self.sky || !self.sharpened.is_empty())
    }

    /// The shadow ray of one light sample at `p` and the radiance it sends towards the
    /// viewer if nothing blocks it (`p.weight` included), times `mis` of the BSDF's
    /// density for the sample's direction (1 for a light only the light's sampling
    /// finds); `None` when it sends nothing.
    fn query(
        &self,
        p: &DirectPoint,
        frame: &Frame,
        ls: &LightSample,
        mis: impl FnOnce(f32) -> f32,
        light: Sampled,
    ) -> Option<ShadowQuery> {
        if !receives(p, ls.wi) {
            return None;
        }
        let (f, bsdf_pdf) = p.bsdf.eval(frame.to_local(p.wo), frame.to_local(ls.wi));
        let c = f * frame.n.dot(ls.wi).abs() * ls.contribution * p.weight * mis(bsdf_pdf);
        shadow_query(p, ls, c, light)
    }

    /// The point of `p`'s pixel (pixel `seed`) where its `n`-th estimate is taken, and its
    /// barycentrics on `p`'s triangle: the `n`-th place of the pixel's R4 sequence on
    /// `p.span`, where that lies on the triangle; `None` (the estimate is taken at `p`
    /// itself) where it does not, or the point has no span, and for the estimates of the
    /// point's first frame ([`Self::first_estimates`]): that frame shows the centre's
    /// light, sharp, and its shadow rays leave from one point (a GPU makes them from its
    /// hit: [`MadeFrom`]); a still pixel's later frames spread the mean over the pixel,
    /// the first frame's weight in it falling as one over their number. A pixel across two triangles
    /// of one surface takes the part beyond its own triangle at its centre: its mean
    /// leans towards the centre's light there, never onto another surface (a
    /// neighbouring triangle may face elsewhere, or be hidden).
    pub fn within_pixel(&self, p: &DirectPoint, seed: u64, n: u64) -> Option<(Vec3, [f32; 2])> {
        if p.span == [Vec3::ZERO; 2] || n < u64::from(self.first_estimates()) {
            return None;
        }
        let s = r_sequence(R4, 12, 0, n, seed) - 0.5;
        let t = r_sequence(R4, 12, 1, n, seed) - 0.5;
        let at = p.position + p.span[0] * s + p.span[1] * t;
        let [a, b, c] = *self.scene.triangle(p.triangle);
        // The point made again from its barycentrics as a hit's is (`surface_point`):
        // a walk that makes its rays from them makes the same point.
        let [u, v] = barycentrics_on(at, a, b, c)?;
        Some((a * (1.0 - u - v) + b * u + c * v, [u, v]))
    }

    /// The shadow rays of the `n`-th estimate at `p` of pixel `seed`'s sequence (one
    /// light sample of each kind), appended to `out`; returns the barycentrics of the
    /// point they leave from where the estimate was moved within the pixel
    /// ([`Self::within_pixel`]).
    pub fn queries(
        &self,
        p: &DirectPoint,
        seed: u64,
        n: u64,
        out: &mut Vec<ShadowQuery>,
    ) -> Option<[f32; 2]> {
        self.each_query(p, seed, n, |q| out.push(q))
    }

    /// Calls `f` with each shadow ray of the `n`-th estimate at `p` of pixel `seed`'s
    /// sequence; returns where it was moved within the pixel, as [`Self::queries`].
    fn each_query(
        &self,
        p: &DirectPoint,
        seed: u64,
        n: u64,
        mut f: impl FnMut(ShadowQuery),
    ) -> Option<[f32; 2]> {
        let within = self.within_pixel(p, seed, n);
        let moved = within.map(|(at, _)| DirectPoint { position: at, ..*p });
        let p = moved.as_ref().unwrap_or(p);
        let frame = Frame::new(p.shading_normal);
        let l = &self.lights;
        if l.has_area() {
            let (first, count) = self.samples_of(n, FIRST_AREA_SAMPLES);
            for k in first..first + count {
                let uc = r_sequence(R3, 3, 0, k, seed);
                let u = Vec2::new(r_sequence(R3, 3, 1, k, seed), r_sequence(R3, 3, 2, k, seed));
                if let Some(mut q) = (l.sample_area(&self.scene, p.position, uc, u))
                    .and_then(|ls| self.query(p, &frame, &ls, |_| 1.0, Sampled::Area))
                {
                    q.radiance /= count as f32;
                    f(q);
                }
            }
        }
        for i in 0..l.punctual.len() {
            if let Some(q) = (l.sample_punctual(i, p.position))
                .and_then(|ls| self.query(p, &frame, &ls, |_| 1.0, Sampled::Punctual(i as u32)))
            {
                f(q);
            }
        }
        let (first, count) = self.samples_of(n, FIRST_SUN_SAMPLES);
        for k in first..first + count {
            let u = Vec2::new(r_sequence(R2, 2, 0, k, seed), r_sequence(R2, 2, 1, k, seed));
            if let Some(mut q) = (l.sample_sun(u))
                .and_then(|ls| self.query(p, &frame, &ls, |_| 1.0, Sampled::Sun(k)))
            {
                q.radiance /= count as f32;
                f(q);
            }
        }
        if self.sky {
            self.sky_queries(p, &frame, seed, n, &mut f);
        } else if self.sharpens(p) {
            self.sharpening_queries(p, &frame, seed, n, &mut f);
        }
        within.map(|(_, uv)| uv)
    }

    /// The sky's two samples of an estimate, combined by multiple importance sampling
    /// (the power heuristic): one direction from the sky's own distribution (good on a
    /// diffuse surface under open sky) and one from the BSDF (good on a glossy one, whose
    /// lobe the sky's distribution rarely hits through a window: alone it left speckles
    /// on the room's glossy floor). Each is a shadow ray to infinity.
    fn sky_queries(
        &self,
        p: &DirectPoint,
        frame: &Frame,
        seed: u64,
        n: u64,
        f: &mut impl FnMut(ShadowQuery),
    ) {
        let Some(sky) = &self.lights.sky else { return };
        // The same 2-D sequence as the sun's, shifted by another hash of the pixel.
        let u = Vec2::new(r_sequence(R2, 4, 0, n, seed), r_sequence(R2, 4, 1, n, seed));
        if let Some(ls) = self.lights.sample_sky(u)
            && let Some(q) = self.query(p, frame, &ls, |b| power_heuristic(ls.pdf, b), Sampled::Sky)
        {
            f(q);
        }
        let uc = r_sequence(R3, 5, 0, n, seed);
        let u = Vec2::new(r_sequence(R3, 5, 1, n, seed), r_sequence(R3, 5, 2, n, seed));
        let Some(b) = p.bsdf.sample(frame.to_local(p.wo), uc, u) else {
            return;
        };
        let wi = frame.to_world(b.wi).normalize();
        if b.delta || !receives(p, wi) {
            return;
        }
        let c = b.weight * sky.radiance(wi) * p.weight * power_heuristic(b.pdf, sky.pdf(wi));
        if let Some(q) = shadow_query(p, &towards_sky(wi, b.pdf), c, Sampled::Sky) {
            f(q);
        }
    }

    /// The sky's reflection at `p` less what its tile's widened lobe reflects,
    /// `∫ (f − f_w)(ω_o, ω_i) L_sky(ω_i) V(ω_i) |cos θ_i| dω_i`, in which the diffuse parts
    /// cancel: one direction from each lobe's visible normals, combined by the balance
    /// heuristic (`Σ g(ω_k) / (p(ω_k) + p_w(ω_k))`), a pair in each estimate. Signed:
    /// around a window's sharp reflection it takes off the widened lobe's halo. The light
    /// field (with its sky) holds the rest.
    fn sharpening_queries(
        &self,
        p: &DirectPoint,
        frame: &Frame,
        seed: u64,
        n: u64,
        f: &mut impl FnMut(ShadowQuery),
    ) {
        let Some(sky) = &self.lights.sky else { return };
        let wo = frame.to_local(p.wo);
        if wo.z == 0.0 {
            return;
        }
        // Both lobes on the viewer's side, as the BSDF mirrors them.
        let side = Vec3::new(1.0, 1.0, wo.z.signum());
        let o = wo * side;
        let lobes = [p.bsdf.ggx(), self.widened];
        let widened = p.bsdf.widened(self.widened.alpha);
        let density = |i: Vec3| -> f32 {
            let h = (o + i).normalize();
            lobes.iter().map(|g| g.visible_pdf(o, h)).sum::<f32>() / (4.0 * o.dot(h))
        };
        let (first, count) = self.samples_of(n, FIRST_SHARPENING_PAIRS);
        for k in first..first + count {
            for (d, lobe) in (6..).zip(&lobes) {
                let u = Vec2::new(r_sequence(R2, d, 0, k, seed), r_sequence(R2, d, 1, k, seed));
                let i = fresnel::reflect(o, lobe.sample_visible(o, u));
                let pdf = density(i);
                if i.z <= 0.0 || !pdf.is_finite() || pdf <= 0.0 {
                    continue;
                }
                let local = i * side;
                let wi = frame.to_world(local).normalize();
                if !receives(p, wi) {
                    continue;
                }
                let g = (p.bsdf.eval(wo, local).0 - widened.eval(wo, local).0) * i.z;
                let c = g * sky.radiance(wi) * p.weight / (pdf * count as f32);
                if let Some(q) = shadow_query(p, &towards_sky(wi, pdf), c, Sampled::Sharpening) {
                    f(q);
                }
            }
        }
    }

    /// What a shadow query brings, given whether the static scene blocks it, with the
    /// moving objects where `placed` puts them.
    pub fn resolve(placed: &PlacedScene, q: &ShadowQuery, static_blocked: bool) -> Estimate {
        if static_blocked {
            return Estimate::default();
        }
        if placed.objects_occluded(&q.ray, q.tmax) {
            return Estimate {
                object_shadow: true,
                ..Estimate::default()
            };
        }
        Estimate {
            radiance: q.radiance,
            sky: if q.light == Sampled::Sky {
                q.radiance
            } else {
                Vec3::ZERO
            },
            object_shadow: false,
        }
    }

    /// The `n`-th estimate at `p` of pixel `seed`'s sequence, with the moving objects
    /// where `placed` puts them: the direct radiance towards the eye, `p.weight`
    /// included.
    pub fn estimate(&self, placed: &PlacedScene, p: &DirectPoint, seed: u64, n: u64) -> Estimate {
        let mut sum = Estimate::default();
        self.each_query(p, seed, n, |q| {
            sum += Self::resolve(placed, &q, self.scene.occluded(&q.ray, q.tmax));
        });
        sum
    }

    /// The shadow query of one sample of the emissive triangles over a flat mirror at `p`
    /// (the tracer's [`Lights::sample_via_mirror`]: `u` picks the mirror, the triangle and
    /// the point; the ray goes to the mirror's image of the light), `p.weight` included,
    /// weighted by the power heuristic against BSDF sampling, which finds the same light
    /// ([`Self::mirror_weight`]); `None` where it brings nothing (a scene without mirrors
    /// or lamps). Not part of [`Self::estimate`]: the walls take light over mirrors from
    /// the light field; a gather sample takes it here and along its bounce.
    pub fn via_mirror(&self, p: &DirectPoint, u: [f32; 4]) -> Option<ShadowQuery> {
        let l = &self.lights;
        if !l.has_mirrors() {
            return None;
        }
        let uv = Vec2::new(u[2], u[3]);
        let ls = l.sample_via_mirror(&self.scene, p.position, u[0], u[1], uv)?;
        let frame = Frame::new(p.shading_normal);
        self.query(
            p,
            &frame,
            &ls,
            |b| power_heuristic(ls.pdf, b),
            Sampled::Other,
        )
    }

    /// The weight of an emitter that BSDF sampling (density `bsdf_pdf`) found over one
    /// delta surface, against [`Self::via_mirror`]: 1 where that cannot find it (glass,
    /// a curved or textured mirror).
    pub fn mirror_weight(&self, bsdf_pdf: f32, over: &OverMirror) -> f32 {
        let l = &self.lights;
        let Some(mirror) = l.mirror_index(over.mirror) else {
            return 1.0;
        };
        let via = ViaMirror {
            bsdf_pdf,
            mirror,
            distance: over.to_mirror,
        };
        let light_pdf = l.mirror_pdf(&via, over.emitter, over.normal, over.dir, over.beyond);
        power_heuristic(bsdf_pdf, light_pdf)
    }

    /// The mean of estimates `first .. first + count` at `p` (pixel `seed`): radiance,
    /// the sky's share of it, whether an object blocked any.
    pub fn mean(
        &self,
        placed: &PlacedScene,
        p: &DirectPoint,
        seed: u64,
        first: u64,
        count: u32,
    ) -> Estimate {
        let count = count.max(1);
        let mut sum = Estimate::default();
        for n in first..first + u64::from(count) {
            sum += self.estimate(placed, p, seed, n);
        }
        mean(&sum, count)
    }
}

/// The sun's samples of pixel `seed` ([`Sampled::Sun`]) for a walk that makes the same
/// shadow rays without f64 (a GPU): component `c` of sample `k` is `shift[c] + ⌊k ·
/// step[c] / 2³²⌋ mod 2³²` in units of 2⁻³², mapped into the sun's disc as the tracer's
/// [`Lights::sample_sun`] maps it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SunSequence {
    pub shift: [u32; 2],
    pub step: [u64; 2],
}

/// See [`SunSequence`].
pub fn sun_sequence(seed: u64) -> SunSequence {
    let (s0, a0) = crate::sequence::r_fixed(R2, 2, 0, seed);
    let (s1, a1) = crate::sequence::r_fixed(R2, 2, 1, seed);
    SunSequence {
        shift: [s0, s1],
        step: [a0, a1],
    }
}

/// The shadow rays a walk makes itself for one pixel from the pixel's first hit: towards
/// every punctual light (`punctual`) and the sun's samples `first_sun .. first_sun + suns`
/// of the pixel's sequence ([`sun_sequence`]), which never cross the bus; and `aimed`
/// rays the CPU chose, the pixel's [`Aim`]s `first_aim .. first_aim + aimed` (points on
/// the area lamps, the sky's directions: their distributions depend on the point and
/// the CPU shades with the samples it draws, so it sends each sample's direction and
/// distance, and the walk makes the ray from its own hit). All from one point: the first
/// hit, or where `at` puts the pixel's one estimate of the frame on the hit's triangle.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MadeRays {
    pub first_sun: u32,
    pub suns: u32,
    pub punctual: bool,
    pub first_aim: u32,
    pub aimed: u32,
    /// The barycentrics on the first hit's triangle of the point the rays leave from,
    /// where the estimate was moved within the pixel ([`PixelDirect::within_pixel`]);
    /// `None`: the first hit itself.
    pub at: Option<[f32; 2]>,
}

/// Where a walk makes a pixel's shadow rays from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MadeFrom {
    /// Nowhere: its rays are sent (its point lies beyond a mirror or glass, or its
    /// estimates this frame leave from more than one point).
    Sent,
    /// The pixel's first hit.
    FirstHit,
    /// This point of the first hit's triangle (barycentrics): the frame's one estimate
    /// moved within the pixel.
    Moved([f32; 2]),
}

/// A light sample as seen from the point that takes it: the direction towards it and its
/// distance (infinite for the sun and the sky). The tracer's `shadow_ray` of these from
/// the point is the sample's shadow ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aim {
    pub dir: Vec3,
    pub dist: f32,
}

/// Bits in a pixel's answer to its [`MadeRays`]: the punctual lights', the sun's samples
/// and the aimed rays together fit in them, or the pixel's rays are sent.
pub const MADE_BITS: u32 = 32;

impl MadeRays {
    /// The rays a walk can make of a pixel's queries (the scene having `lights` punctual
    /// lights): its punctual lights', its sun's samples and, where they fit in
    /// [`MADE_BITS`] as well, the rest aimed (`first_aim` left to the caller); none where
    /// the first two do not fit.
    fn of(queries: &[ShadowQuery], lights: u32) -> MadeRays {
        let mut m = MadeRays::default();
        let (mut lo, mut hi) = (u64::MAX, 0);
        let mut aimed = 0;
        for q in queries {
            match q.light {
                Sampled::Punctual(_) => m.punctual = true,
                Sampled::Sun(k) => (lo, hi) = (lo.min(k), hi.max(k)),
                _ => aimed += 1,
            }
        }
        if lo <= hi {
            let (Ok(first), Ok(suns)) = (u32::try_from(lo), u32::try_from(hi - lo + 1)) else {
                return MadeRays::default();
            };
            (m.first_sun, m.suns) = (first, suns);
        }
        if lights + m.suns > MADE_BITS {
            return MadeRays::default();
        }
        if lights + m.suns + aimed <= MADE_BITS {
            m.aimed = aimed;
        }
        m
    }

    /// The bit of each of a pixel's `queries` in its answer where the walk makes the
    /// ray (`lights` punctual lights first, then the sun's samples, then the aimed rays
    /// in the order of the queries); `None` for a ray sent.
    pub fn bits(&self, queries: &[ShadowQuery], lights: u32) -> Vec<Option<u32>> {
        let mut aimed = 0;
        (queries.iter())
            .map(|q| match q.light {
                Sampled::Punctual(i) => self.punctual.then_some(i),
                Sampled::Sun(k) => {
                    let j = k.checked_sub(u64::from(self.first_sun))?;
                    (j < u64::from(self.suns)).then(|| lights + j as u32)
                }
                _ => {
                    aimed += 1;
                    (aimed <= self.aimed).then(|| lights + self.suns + aimed - 1)
                }
            })
            .collect()
    }
}

/// What the walk makes of each pixel's `queries`, made from where `from` says, the
/// scene having `lights` punctual lights: each pixel's [`MadeRays`] and the aims of all
/// of them in order.
pub fn made_rays(
    queries: &[Vec<ShadowQuery>],
    from: &[MadeFrom],
    lights: u32,
) -> (Vec<MadeRays>, Vec<Aim>) {
    let mut plans: Vec<MadeRays> = (queries.par_iter().zip(from))
        .map(|(q, from)| match *from {
            MadeFrom::Sent => MadeRays::default(),
            MadeFrom::FirstHit => MadeRays::of(q, lights),
            MadeFrom::Moved(at) => MadeRays {
                at: Some(at),
                ..MadeRays::of(q, lights)
            },
        })
        .collect();
    let mut aims = Vec::new();
    for (m, q) in plans.iter_mut().zip(queries) {
        m.first_aim = aims.len() as u32;
        if m.aimed > 0 {
            let aimed = q
                .iter()
                .filter(|q| !matches!(q.light, Sampled::Punctual(_) | Sampled::Sun(_)));
            aims.extend(aimed.map(|q| q.aim));
        }
    }
    (plans, aims)
}

/// Shadow rays a walk makes from the pixels' first hits where it found them (a GPU,
/// from the wall's hits it keeps): neither the hits nor the rays cross the bus, only
/// each pixel's [`MadeRays`], the aims of the rays the CPU chose, and its answer (a bit a
/// ray).
pub struct Made<'a> {
    /// Per pixel: whether the point it sees is the walk's first hit of its ray (no mirror,
    /// glass or moving object in between).
    pub at_first_hit: &'a [bool],
    /// Whether the static scene blocks each pixel's made rays (the aims of all pixels
    /// given): bit `i` for punctual light `i`, bit `P + j` for the sun's sample
    /// `first_sun + j`, bit `P + S + a` for the pixel's aim `first_aim + a` (`P` punctual
    /// lights, `S` sun samples).
    pub trace: &'a TraceMade<'a>,
}

/// What [`Made::trace`] calls: each pixel's plan and the aims of all of them in, each
/// pixel's answer out.
pub type TraceMade<'a> = dyn Fn(&[MadeRays], &[Aim]) -> Vec<u32> + Sync + 'a;

/// One light sample's shadow ray (up to `tmax`) and the radiance it sends towards the
/// viewer if nothing blocks it.
#[derive(Clone, Copy, Debug)]
pub struct ShadowQuery {
    pub ray: Ray,
    pub tmax: f32,
    pub radiance: Vec3,
    pub light: Sampled,
    /// The light sample the ray was made for, from the point that takes it.
    pub aim: Aim,
}

/// What a shadow query samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sampled {
    /// A point on the emissive triangles.
    Area,
    /// The scene's punctual light of this index.
    Punctual(u32),
    /// This sample of the pixel's sequence in the sun's disc ([`sun_sequence`]).
    Sun(u64),
    /// A direction of the sky's direct light ([`PixelDirect::with_sky`]).
    Sky,
    /// The sky's sharpened reflection ([`PixelDirect::with_sharp_sky_reflections`]).
    Sharpening,
    /// An emitter over a mirror.
    Other,
}

/// The light an estimate at a point adds beside its shadow rays' (a moving object's own
/// indirect light: [`crate::object_gather`]): `gather(p, seed, n)` for pixel `seed`'s
/// `n`-th estimate at `p`.
pub type Gather<'a> = dyn Fn(&DirectPoint, u64, u64) -> Vec3 + Sync + 'a;

/// One estimate of the direct light at a point.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Estimate {
    pub radiance: Vec3,
    /// The sky's share of `radiance` ([`PixelDirect::with_sky`]; zero without).
    pub sky: Vec3,
    /// A moving object blocked one of its shadow rays.
    pub object_shadow: bool,
}

impl std::ops::AddAssign for Estimate {
    fn add_assign(&mut self, o: Estimate) {
        self.radiance += o.radiance;
        self.sky += o.sky;
        self.object_shadow |= o.object_shadow;
    }
}

/// The running mean of the direct light per surface point over frames: each pixel keeps
/// the point it saw last and the mean of its estimates there, adding one estimate a
/// frame; when a pixel sees another point (the view moved, another surface came in
/// front), its mean is carried over ([`Accumulator::reproject`]) or starts again from
/// that frame's [`PixelDirect::first_estimates`]. Moving an object changes the light at
/// points that stay put: [`Accumulator::restart_where`] starts their means again.
#[derive(Default)]
pub struct Accumulator {
    seen: Vec<Option<MeanSite>>,
    sum: Vec<Estimate>,
    count: Vec<u32>,
    /// The spread of each pixel's frames, and the rule by which a mean needs no more
    /// estimates (`None`: every pixel takes one every frame).
    spread: Vec<Spread>,
    settling: Option<Settling>,
    /// Frames added so far (the settled pixels' turns to look again).
    frame: u64,
    /// How many pixels took estimates in the last frame added.
    taken: usize,
    /// This frame's means were carried over from another view ([`Self::reproject`]): its
    /// estimates are taken at the pixels' points, not spread over the pixels
    /// ([`DirectPoint::span`]). A carried mean already holds estimates from points a
    /// footprint apart; spread over each pixel as well, it would average over two
    /// (measured: the Cornell box in motion 1.98e-3 taken at the points, 2.02e-3 spread,
    /// against 1.97e-3 before either). A still view spreads them, and its pixels' means
    /// become the means over their patches.
    carried: bool,
    /// The pixels that take no estimate in the next frame added: they show what they
    /// carried from the last frame ([`crate::carry`]), and their means wait, as they were,
    /// for their turn to be drawn anew ([`Self::hold`]).
    held: Vec<bool>,
}

/// Whether two points of one triangle are the same point: equal up to the rounding of
/// the eye rays that found them (a still view finds them bit for bit; 1e-5 of their size
/// allows for a few roundings of an f32 position).
pub fn same_point(a: Vec3, b: Vec3) -> bool {
    (a - b).length() <= 1e-5 * (1.0 + a.abs().max_element())
}

/// Where a pixel's mean was made: the triangle, the point the pixel saw last, and the
/// point the mean began at. Every estimate in the mean was taken within a pixel's
/// footprint of `anchor`: a mean carried from pixel to pixel as the eye moves stays
/// there, and never drifts across a shadow's edge to smear it along the motion.
#[derive(Clone, Copy, Debug, PartialEq)]
struct MeanSite {
    triangle: u32,
    last: Vec3,
    anchor: Vec3,
}

/// What a pixel keeps between frames: where its mean was made, the sum of its estimates,
/// their count and their frames' spread.
type PixelMean = (Option<MeanSite>, Estimate, u32, Spread);

/// Estimates a pixel whose point is `p` takes this frame: one more at the point it saw
/// last, else (its mean started again) [`PixelDirect::first_estimates`]; none where it sees
/// no point (its mean forgotten).
fn start(
    direct: &PixelDirect,
    p: Option<&DirectPoint>,
    seen: &mut Option<MeanSite>,
    (sum, count, spread): (&mut Estimate, &mut u32, &mut Spread),
) -> u32 {
    let Some(p) = p else {
        *seen = None;
        (*sum, *count, *spread) = Default::default();
        return 0;
    };
    if seen.is_some_and(|s| s.triangle == p.triangle && same_point(s.last, p.position)) {
        return 1;
    }
    *seen = Some(MeanSite {
        triangle: p.triangle,
        last: p.position,
        anchor: p.position,
    });
    (*sum, *count, *spread) = Default::default();
    direct.first_estimates()
}

/// The running mean of `count` estimates summing to `sum` (zero for none).
fn mean(sum: &Estimate, count: u32) -> Estimate {
    if count == 0 {
        return Estimate::default();
    }
    Estimate {
        radiance: sum.radiance / count as f32,
        sky: sum.sky / count as f32,
        object_shadow: sum.object_shadow,
    }
}

impl Accumulator {
    pub fn new() -> Self {
        Accumulator::default()
    }

    /// The same, a pixel whose mean is settled by `settling` taking no estimate but in
    /// its turn to look again ([`crate::settling`]).
    pub fn settling(settling: Settling) -> Self {
        Accumulator {
            settling: Some(settling),
            ..Accumulator::default()
        }
    }

    /// How many pixels took estimates in the last frame added.
    pub fn taken(&self) -> usize {
        self.taken
    }

    /// How many estimates each pixel's mean holds (after [`Self::add`]: this frame's
    /// included).
    pub fn counts(&self) -> &[u32] {
        &self.count
    }

    /// Marks the pixels (`held[i]`) that take no estimate in the next frame added.
    pub fn hold(&mut self, held: Vec<bool>) {
        self.held = held;
    }

    /// Forgets every pixel's mean (a view it cannot be carried to).
    pub fn restart(&mut self) {
        self.seen.iter_mut().for_each(|s| *s = None);
    }

    /// Forgets the means of the pixels whose light `changed(triangle, point)` says changed
    /// where their estimates were taken (asked of the point a mean began at and of the
    /// one seen last): a moved object changes the light in its shadows and beside it, and
    /// every other pixel's mean goes on.
    pub fn restart_where(&mut self, changed: impl Fn(u32, Vec3) -> bool + Sync) {
        self.seen.par_iter_mut().for_each(|seen| {
            if seen.is_some_and(|s| changed(s.triangle, s.anchor) || changed(s.triangle, s.last)) {
                *seen = None;
            }
        });
    }

    /// Adds one frame's estimate at every pixel's point (`None`: nothing non-delta seen),
    /// with the moving objects where `placed` puts them, each with what `gather` adds
    /// there, and returns every pixel's running mean (zero where there is no point), each
    /// marked if a moving object blocked any of its estimates.
    pub fn add(
        &mut self,
        direct: &PixelDirect,
        placed: &PlacedScene,
        points: &[Option<DirectPoint>],
        gather: &Gather,
    ) -> Vec<Estimate> {
        let (means, takes) = self.each_pixel(direct, points, |i, p, first, take, sum| {
            if let Some(p) = p {
                for n in first..first + u64::from(take) {
                    *sum += direct.estimate(placed, p, i as u64, n);
                    sum.radiance += gather(p, i as u64, n);
                }
            }
            mean(sum, first as u32 + take)
        });
        self.spread_by(&takes);
        means
    }

    /// Adds this frame's batch of each pixel to its spread: `takes` its estimates and
    /// the luminance of its sum before them.
    fn spread_by(&mut self, takes: &[(u32, f32)]) {
        (self.spread.par_iter_mut().zip(&self.sum))
            .zip(takes)
            .for_each(|((spread, sum), &(take, before))| {
                spread.add(luminance(sum) - before, take);
            });
    }

    /// For every pixel (sized for `points`): its mean started again where it sees another
    /// point, then `f(pixel, point, first, take, sum)` for the estimates `first ..
    /// first + take` it takes this frame (none where its mean is settled and it is not its
    /// turn), after which its count includes them. Each pixel's result, and its take with
    /// the luminance of its sum before it (for [`Self::spread_by`]).
    fn each_pixel<T: Send>(
        &mut self,
        direct: &PixelDirect,
        points: &[Option<DirectPoint>],
        f: impl Fn(usize, Option<&DirectPoint>, u64, u32, &mut Estimate) -> T + Sync,
    ) -> (Vec<T>, Vec<(u32, f32)>) {
        self.fit(points.len());
        let carried = std::mem::take(&mut self.carried);
        let held = std::mem::take(&mut self.held);
        let (settling, frame) = (self.settling, self.frame);
        self.frame += 1;
        let out: (Vec<T>, Vec<(u32, f32)>) = points
            .par_iter()
            .zip(self.seen.par_iter_mut())
            .zip(self.sum.par_iter_mut())
            .zip(self.count.par_iter_mut())
            .zip(self.spread.par_iter_mut())
            .enumerate()
            .map(|(i, ((((p, seen), sum), count), spread))| {
                let at_point = p.filter(|_| carried).map(|p| DirectPoint {
                    span: [Vec3::ZERO; 2],
                    ..p
                });
                let p = at_point.as_ref().or(p.as_ref());
                let mut take = start(direct, p, seen, (sum, count, spread));
                if held.get(i).copied().unwrap_or(false) {
                    // A mean that starts again waits to start whole, with its first
                    // estimates, when its pixel is drawn anew.
                    if take > 1 {
                        *seen = None;
                    }
                    take = 0;
                } else if take == 1
                    && let Some(rule) = settling
                    && rule.settled(sum, *count, spread)
                    && !rule.refreshes(i, frame)
                {
                    take = 0;
                }
                let before = luminance(sum);
                let out = f(i, p, u64::from(*count), take, sum);
                *count += take;
                (out, (take, before))
            })
            .unzip();
        self.taken = out.1.iter().filter(|(take, _)| *take > 0).count();
        out
    }

    /// Carries every pixel's mean over from the view `from` these means were made in to
    /// the view `to`, whose pixels see `points` (the eye moved): a pixel whose point, seen
    /// from `from`, lies in a pixel that saw the same triangle, within a pixel's footprint
    /// of where that pixel's mean began, takes that mean and goes on adding to it. Its
    /// estimates were of the light there, which differs only across a shadow's edge within
    /// the footprint — the image's own resolution. Measured from where the mean began, not
    /// from the point seen last: carried on frame after frame, a mean would otherwise creep
    /// a footprint at a time along the eye's motion and drag the light of a lit patch into
    /// the umbra beside it. Other pixels start again (a point newly in sight, one that has
    /// moved a footprint from where its mean began, or one seen in a mirror, whose image
    /// moves otherwise).
    pub fn reproject(&mut self, from: &WallView, to: &WallView, points: &[Option<DirectPoint>]) {
        let (w, h) = (from.size.width as usize, from.size.height as usize);
        if self.seen.len() != w * h || points.len() != to.size.area() {
            self.restart();
            return;
        }
        let screen = Screen::of(from, 1);
        let (seen, sum, count, spread) = (&self.seen, &self.sum, &self.count, &self.spread);
        let carried: Vec<PixelMean> = points
            .par_iter()
            .map(|p| {
                let none = (None, Estimate::default(), 0, Spread::default());
                let Some(p) = p else { return none };
                let v = p.position - from.eye;
                let Some((x, y)) = from.project(v.as_dvec3()) else {
                    return none;
                };
                if !(x >= 0.0 && y >= 0.0 && x < w as f64 && y < h as f64) {
                    return none;
                }
                let j = y as usize * w + x as usize;
                match seen[j] {
                    Some(s)
                        if s.triangle == p.triangle
                            && screen.footprint(p, 1.0).contains(s.anchor) =>
                    {
                        let carried = MeanSite {
                            last: p.position,
                            ..s
                        };
                        (Some(carried), sum[j], count[j], spread[j])
                    }
                    _ => none,
                }
            })
            .collect();
        (self.seen, self.sum, self.count, self.spread) = (
            carried.iter().map(|c| c.0).collect(),
            carried.iter().map(|c| c.1).collect(),
            carried.iter().map(|c| c.2).collect(),
            carried.iter().map(|c| c.3).collect(),
        );
        self.carried = true;
    }

    /// Sized for `n` pixels (a new size forgets every mean).
    fn fit(&mut self, n: usize) {
        if self.seen.len() != n {
            self.seen = vec![None; n];
            self.sum = vec![Estimate::default(); n];
            self.count = vec![0; n];
            self.spread = vec![Spread::default(); n];
        }
    }

    /// [`Self::add`], with the frame's shadow rays against the static scene traced all at
    /// once by `traced` (the CPU's walk, or the GPU's), each pixel's a group; with
    /// `made`, the punctual lights' and the sun's rays of the pixels that see their first
    /// hit are made by the walk instead. The moving objects, and what `gather` adds, are
    /// taken on the CPU.
    pub fn add_blocked(
        &mut self,
        direct: &PixelDirect,
        placed: &PlacedScene,
        points: &[Option<DirectPoint>],
        (traced, made): (&dyn StaticRays, Option<&Made>),
        gather: &Gather,
    ) -> Vec<Estimate> {
        // The estimates each pixel takes this frame, as shadow rays, and where they leave
        // from for a walk that makes them from the pixel's first hit's triangle; and what
        // they gather.
        let (planned, takes) = self.each_pixel(direct, points, |i, p, first, take, _| {
            let mut queries = Vec::new();
            let mut from = MadeFrom::FirstHit;
            let mut gathered = Vec3::ZERO;
            if let Some(p) = p {
                for n in first..first + u64::from(take) {
                    from = match (direct.queries(p, i as u64, n, &mut queries), take) {
                        (None, _) if from == MadeFrom::FirstHit => from,
                        (Some(at), 1) => MadeFrom::Moved(at),
                        _ => MadeFrom::Sent,
                    };
                    gathered += gather(p, i as u64, n);
                }
            }
            ((queries, from), gathered)
        });
        let (planned, gathered): (Vec<_>, Vec<Vec3>) = planned.into_iter().unzip();
        let (per_pixel, from): (Vec<Vec<ShadowQuery>>, Vec<MadeFrom>) = planned.into_iter().unzip();
        let lights = direct.lights.punctual.len() as u32;
        let n = points.len();
        // What the walk makes of each pixel's queries (each query's bit in the pixel's
        // answer; none without `made`) and its answers to them.
        let (bits, masks): (Vec<Vec<Option<u32>>>, Vec<u32>) = match made {
            Some(made) => {
                let from: Vec<MadeFrom> = (made.at_first_hit.iter().zip(from))
                    .map(|(&first, from)| if first { from } else { MadeFrom::Sent })
                    .collect();
                let (plans, aims) = made_rays(&per_pixel, &from, lights);
                let masks = (made.trace)(&plans, &aims);
                let bits = (per_pixel.par_iter().zip(&plans))
                    .map(|(queries, m)| m.bits(queries, lights))
                    .collect();
                (bits, masks)
            }
            None => (vec![Vec::new(); n], vec![0; n]),
        };
        let bit = |bits: &[Option<u32>], k: usize| bits.get(k).copied().flatten();
        // The rest are sent: all of them without `made`.
        let sent: Option<Vec<Vec<ShadowQuery>>> = made.map(|_| {
            (per_pixel.par_iter().zip(&bits))
                .map(|(queries, bits)| {
                    let unmade = queries
                        .iter()
                        .enumerate()
                        .filter(|&(k, _)| bit(bits, k).is_none());
                    unmade.map(|(_, q)| *q).collect()
                })
                .collect()
        });
        let sent = sent.as_ref().unwrap_or(&per_pixel);
        let answers = traced.blocked(sent);
        let answers = per_group(sent, &answers);
        let means = (per_pixel.par_iter().zip(&bits).zip(masks))
            .zip(answers)
            .zip(self.sum.par_iter_mut().zip(gathered))
            .zip(self.count.par_iter())
            .map(
                |(((((queries, bits), mask), answers), (sum, gathered)), &count)| {
                    sum.radiance += gathered;
                    let mut sent = answers.iter();
                    for (k, q) in queries.iter().enumerate() {
                        let b = match bit(bits, k) {
                            Some(bit) => mask & (1 << bit) != 0,
                            None => *sent.next().unwrap_or(&true),
                        };
                        *sum += PixelDirect::resolve(placed, q, b);
                    }
                    mean(sum, count)
                },
            )
            .collect();
        self.spread_by(&takes);
        means
    }

    /// Frames averaged at pixel `i` so far.
    pub fn frames(&self, i: usize) -> u32 {
        self.count.get(i).copied().unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn query(light: Sampled) -> ShadowQuery {
        let aim = Aim {
            dir: Vec3::Y,
            dist: if light == Sampled::Area {
                2.0
            } else {
                f32::INFINITY
            },
        };
        ShadowQuery {
            ray: Ray::new(Vec3::ZERO, Vec3::Y),
            tmax: aim.dist,
            radiance: Vec3::ONE,
            light,
            aim,
        }
    }

    /// The answer's bits: punctual lights, then the sun's samples, then the aims in the
    /// queries' order; aims that do not fit are sent, and so is everything of a pixel
    /// whose lights and sun samples do not fit or whose point lies beyond a mirror.
    #[test]
    fn made_rays_lay_out_each_pixels_answer() {
        let lights = 3;
        let mut first: Vec<ShadowQuery> = vec![query(Sampled::Area)];
        first.extend((0..3).map(|i| query(Sampled::Punctual(i))));
        first.extend([Sampled::Sun(5), Sampled::Sun(6), Sampled::Sky].map(query));
        let mut crowded: Vec<ShadowQuery> = (0..28).map(|k| query(Sampled::Sun(k))).collect();
        crowded.extend([Sampled::Area, Sampled::Other].map(query));
        let too_many: Vec<ShadowQuery> = (0..30).map(|k| query(Sampled::Sun(k))).collect();
        let pixels = [
            first.clone(),
            crowded.clone(),
            too_many.clone(),
            first.clone(),
            first.clone(),
        ];
        let moved = MadeFrom::Moved([0.25, 0.5]);
        let from = [
            MadeFrom::FirstHit,
            MadeFrom::FirstHit,
            MadeFrom::FirstHit,
            MadeFrom::Sent,
            moved,
        ];
        let (plans, aims) = made_rays(&pixels, &from, lights);
        let expected_first = MadeRays {
            first_sun: 5,
            suns: 2,
            punctual: true,
            first_aim: 0,
            aimed: 2,
            at: None,
        };
        assert_eq!(plans[0], expected_first);
        assert_eq!(
            plans[0].bits(&first, lights),
            [5, 0, 1, 2, 3, 4, 6].map(Some).to_vec()
        );
        // The first pixel's two aims, and the last one's.
        assert_eq!(aims.len(), 4);
        assert_eq!(aims[0].dist, 2.0);
        assert!(aims[1].dist.is_infinite());
        // 3 lights and 28 samples leave one bit: both aims are sent.
        assert_eq!(
            (plans[1].suns, plans[1].aimed, plans[1].first_aim),
            (28, 0, 2)
        );
        let bits = plans[1].bits(&crowded, lights);
        assert_eq!(bits[27], Some(30));
        assert_eq!(bits[28..], [None, None]);
        // 3 + 30 bits do not fit: nothing is made.
        assert_eq!(
            plans[2],
            MadeRays {
                first_aim: 2,
                ..MadeRays::default()
            }
        );
        assert!(plans[2].bits(&too_many, lights).iter().all(Option::is_none));
        assert!(plans[3].bits(&first, lights).iter().all(Option::is_none));
        // Moved within the pixel: the same rays, from the point given.
        assert_eq!(
            plans[4],
            MadeRays {
                first_aim: 2,
                at: Some([0.25, 0.5]),
                ..expected_first
            }
        );
    }
}
