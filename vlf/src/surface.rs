//! How the light field treats a surface: a **diffuse** element (Lambertian, with the
//! albedo the material reflects in all), a **glossy** element (a GGX lobe with `α` below
//! the bake's threshold: its outgoing radiance over directions is kept in a directional
//! radiance tile, `tiles`), or a **delta** surface (a perfect mirror or smooth glass),
//! through which lines and eye rays continue exactly.
//!
//! Non-delta materials rougher than the threshold, rough glass, and a mix of a delta lobe
//! with a diffuse one (a half-metallic mirror) are drawn as diffuse with their whole
//! albedo: the energy they reflect is right, and each line and each eye takes the share
//! of it that its direction gets under even light (`exitance`, [`albedo_towards`]).

use std::collections::HashMap;
use std::sync::{OnceLock, RwLock};

use glam::{Vec2, Vec3};
use holocave_scene::{Hit, PlacedScene, Ray, Scene, SurfaceParams};
use holocave_tracer::bsdf::Bsdf;
use holocave_tracer::frame::Frame;
use holocave_tracer::fresnel;
use holocave_tracer::integrator::shadow_ray;
use holocave_tracer::lights::Lights;
use holocave_tracer::microfacet::Ggx;
use rayon::prelude::*;

use crate::StaticRays;
use crate::pixel_direct::DirectPoint;
use crate::sequence::{R3, r_sequence};

/// The most delta surfaces followed in a row before a line or eye ray gives up (black).
pub const MAX_DELTA_DEPTH: u32 = 8;

/// The fraction of light a non-delta surface reflects, as one Lambertian albedo: the
/// tracer's BSDF's own bihemispherical albedo `(1/π) ∫∫ f cos θo cos θi dωi dωo` (the
/// light it sends out, all directions together, under light arriving evenly from all
/// directions), so that what the light field passes on from bounce to bounce is what the
/// path tracer's surfaces reflect. That is less than the base colour for a rough
/// dielectric (its Lambertian base is dimmed by the Fresnel transmission in and out,
/// `(1 − F(θo))(1 − F(θi))`, which grows towards grazing angles) and for a rough metal
/// (single-scattering GGX loses what scatters between microfacets). It was once
/// `base (1 − F0)² + F0`, the normal-incidence value: 7 % too much on the breakfast
/// room's white walls, which the walls' inter-reflection made 25 % too bright.
///
/// The BSDF is affine in the base colour (every lobe is either independent of it or
/// proportional to it, Schlick's metal Fresnel `F0 + (1 − F0)(1 − c)⁵` with `F0 = base`
/// included), so the albedo is `a + b · base` with `a`, `b` depending on the other
/// parameters only; those two are integrated once per distinct set (metallic and
/// roughness quantised to 1/1024, finer than an 8-bit texture) and kept.
pub fn diffuse_albedo(p: &SurfaceParams) -> Vec3 {
    let (a, b) = albedo_terms(p);
    (a + b * p.base_color).clamp(Vec3::ZERO, Vec3::ONE)
}

pub(crate) type AlbedoKey = [u32; 8];

/// `p` with its base colour and emission zero and its metallic and roughness quantised to
/// 1/1024 (finer than an 8-bit texture), as an albedo's tables are integrated, and the key
/// they are kept under.
fn albedo_params(p: &SurfaceParams) -> (SurfaceParams, AlbedoKey) {
    let q = SurfaceParams {
        base_color: Vec3::ZERO,
        emission: Vec3::ZERO,
        metallic: quantised(p.metallic),
        roughness: quantised(p.roughness),
        ..*p
    };
    (q, albedo_key(&q))
}

/// The parameters an albedo depends on besides the base colour.
fn albedo_key(q: &SurfaceParams) -> AlbedoKey {
    [
        q.metallic.to_bits(),
        q.roughness.to_bits(),
        q.specular.to_bits(),
        q.specular_color.x.to_bits(),
        q.specular_color.y.to_bits(),
        q.specular_color.z.to_bits(),
        q.transmission.to_bits(),
        q.ior.to_bits(),
    ]
}

fn albedo_cache() -> &'static RwLock<HashMap<AlbedoKey, (Vec3, Vec3)>> {
    static CACHE: OnceLock<RwLock<HashMap<AlbedoKey, (Vec3, Vec3)>>> = OnceLock::new();
    CACHE.get_or_init(|| RwLock::new(HashMap::new()))
}

fn quantised(x: f32) -> f32 {
    (x.clamp(0.0, 1.0) * 1024.0).round() / 1024.0
}

/// `a` and `b` of [`diffuse_albedo`] for the parameters of `p` other than its base
/// colour and emission.
fn albedo_terms(p: &SurfaceParams) -> (Vec3, Vec3) {
    let (q, key) = albedo_params(p);
    // Neighbouring pixels mostly see one material: the last answer, kept per thread,
    // spares the shared map's lock and hash (7 % of a wall's per-pixel work).
    thread_local! {
        static LAST: std::cell::Cell<Option<(AlbedoKey, (Vec3, Vec3))>> =
            const { std::cell::Cell::new(None) };
    }
    if let Some((k, t)) = LAST.get()
        && k == key
    {
        return t;
    }
    let cached = albedo_cache()
        .read()
        .unwrap_or_else(|e| e.into_inner())
        .get(&key)
        .copied();
    let t = cached.unwrap_or_else(|| integrate_albedo_terms(key, &q));
    LAST.set(Some((key, t)));
    t
}

/// Integrates `a` and `b` of [`diffuse_albedo`] for `q` (its base colour zero) and keeps
/// them under `key`.
fn integrate_albedo_terms(key: AlbedoKey, q: &SurfaceParams) -> (Vec3, Vec3) {
    let a = bihemispherical_albedo(q);
    let b = bihemispherical_albedo(&SurfaceParams {
        base_color: Vec3::ONE,
        ..*q
    }) - a;
    albedo_cache()
        .write()
        .unwrap_or_else(|e| e.into_inner())
        .insert(key, (a, b));
    (a, b)
}

/// Entries of a material's [`albedo_towards`] table over `cos θ_o ∈ [0, 1]`.
pub const TOWARDS_STEPS: usize = 32;

/// The fraction of light arriving evenly from all directions that a non-delta surface
/// sends towards a viewer at `cos_o` (the cosine between its shading normal and the
/// view), times π: its directional albedo `∫ f cos θi dωi`. Under an even light of
/// irradiance `E` the surface's radiance towards the viewer is this times `E/π`, where
/// [`diffuse_albedo`] (its mean over the views) is what the light field passes on from
/// bounce to bounce. A rough dielectric's Lambertian base is dimmed by the Fresnel
/// transmission out, `1 − F(θo)`, which grows towards grazing views, and its specular
/// lobe rises there; a Lambertian surface's is its albedo at every view.
pub fn albedo_towards(p: &SurfaceParams, cos_o: f32) -> Vec3 {
    let (i, f) = table_step(cos_o.abs(), TOWARDS_STEPS);
    with_towards_terms(p, |table| {
        let at = |k: usize| table[k].0 + table[k].1 * p.base_color;
        (at(i) * (1.0 - f) + at(i + 1) * f).clamp(Vec3::ZERO, Vec3::ONE)
    })
}

type TowardsTable = std::sync::Arc<Vec<(Vec3, Vec3)>>;

/// Calls `f` with `a` and `b` of [`albedo_towards`] (`a + b · base`, affine in the base
/// colour as [`diffuse_albedo`] is) over `cos θ_o`, for the parameters of `p` other than
/// its base colour and emission; integrated once per distinct set and kept.
fn with_towards_terms<R>(p: &SurfaceParams, f: impl FnOnce(&[(Vec3, Vec3)]) -> R) -> R {
    static CACHE: OnceLock<RwLock<HashMap<AlbedoKey, TowardsTable>>> = OnceLock::new();
    let cache = CACHE.get_or_init(|| RwLock::new(HashMap::new()));
    let (q, key) = albedo_params(p);
    // Neighbouring pixels mostly see one material (as in `albedo_terms`); the last table
    // is read in place, not cloned: threads cloning one shared table fought over its
    // reference count (a tenth of a wall's per-pixel work on two cores).
    thread_local! {
        static LAST: std::cell::RefCell<Option<(AlbedoKey, TowardsTable)>> =
            const { std::cell::RefCell::new(None) };
    }
    let found = LAST.with_borrow(|l| l.as_ref().is_some_and(|(k, _)| *k == key));
    if !found {
        let cached = cache
            .read()
            .unwrap_or_else(|e| e.into_inner())
            .get(&key)
            .cloned();
        let table = cached.unwrap_or_else(|| {
            let table = integrate_towards_terms(&q);
            (cache.write().unwrap_or_else(|e| e.into_inner())).insert(key, table.clone());
            table
        });
        LAST.set(Some((key, table)));
    }
    LAST.with_borrow(|l| f(&l.as_ref().expect("the table was just kept").1))
}

/// [`albedo_towards`]'s table for `p`: `a + b · base` at each of [`TOWARDS_STEPS`] views
/// evenly over `cos θ_o ∈ [0, 1]`.
pub fn towards_table(p: &SurfaceParams) -> Vec<(Vec3, Vec3)> {
    with_towards_terms(p, |table| table.to_vec())
}

/// The parameters of `p` that [`towards_table`] depends on (all but the base colour and
/// emission), as a key.
pub(crate) fn albedo_key_of(p: &SurfaceParams) -> AlbedoKey {
    albedo_params(p).1
}

/// The table of [`with_towards_terms`] for `q` (its base colour zero).
fn integrate_towards_terms(q: &SurfaceParams) -> TowardsTable {
    let (black, white) = (
        Bsdf::new(q),
        Bsdf::new(&SurfaceParams {
            base_color: Vec3::ONE,
            ..*q
        }),
    );
    std::sync::Arc::new(
        (0..TOWARDS_STEPS)
            .map(|k| {
                let wo = at_cos(k, TOWARDS_STEPS).max(Vec3::new(0.0, 0.0, 1e-3));
                let a = reflected_albedo(&black, wo);
                (a, reflected_albedo(&white, wo) - a)
            })
            .collect(),
    )
}

/// `bsdf`'s directional albedo towards `wo` (local), of reflection alone (what a side's
/// element shows; light it lets through belongs to the other side).
fn reflected_albedo(bsdf: &Bsdf, wo: Vec3) -> Vec3 {
    const SAMPLES: u32 = 4096;
    let at = |c: i32, n: u32| r_sequence(R3, 6, c, u64::from(n), 0);
    let sum: Vec3 = (0..SAMPLES)
        .filter_map(|n| bsdf.sample(wo, at(0, n), Vec2::new(at(1, n), at(2, n))))
        .filter(|b| b.wi.z > 0.0 && b.weight.is_finite())
        .map(|b| b.weight)
        .sum();
    sum / SAMPLES as f32
}

/// The local direction at entry `i` of a table of `n` entries evenly over `cos θ ∈ [0, 1]`
/// (an isotropic BSDF's albedo does not depend on the azimuth).
pub(crate) fn at_cos(i: usize, n: usize) -> Vec3 {
    let cos = i as f32 / (n - 1) as f32;
    Vec3::new((1.0 - cos * cos).max(0.0).sqrt(), 0.0, cos)
}

/// Where `x` (clamped to `[0, 1]`) falls in a table of `n` entries evenly over `[0, 1]`:
/// the entry below it and the fraction of the way to the next.
pub(crate) fn table_step(x: f32, n: usize) -> (usize, f32) {
    let at = x.clamp(0.0, 1.0) * (n - 1) as f32;
    let i = (at as usize).min(n - 2);
    (i, at - i as f32)
}

/// `∫ f(ω_o, ω_i) |cos θ_i| dω_i` seen from `wo` (local): the mean weight of `samples` of
/// the BSDF's own sampling, the lobe's choice and the direction from the 3-D R sequence
/// (deterministic; a delta lobe's weight is exact). By reciprocity also the albedo of
/// light arriving from `wo`.
pub(crate) fn directional_albedo(bsdf: &Bsdf, wo: Vec3, samples: u32) -> Vec3 {
    let at = |c: i32, n: u32| r_sequence(R3, 6, c, u64::from(n), 0);
    let sum: Vec3 = (0..samples)
        .filter_map(|n| bsdf.sample(wo, at(0, n), Vec2::new(at(1, n), at(2, n))))
        .map(|b| b.weight)
        .filter(|w| w.is_finite())
        .sum();
    sum / samples as f32
}

/// Views of the albedo's integral over `cos θ_o`.
const VIEWS: u32 = 64;

/// `(1/π) ∫∫ f cos θo cos θi dωi dωo` over reflection: the mean over views of what each
/// reflects ([`reflected_albedo`], the BSDF's own sampling), the views cosine-weighted,
/// one in each of [`VIEWS`] equal steps of `cos² θ_o` (an isotropic BSDF's albedo does not
/// depend on the azimuth); deterministic, so a bake stays bit for bit the same. Within
/// 0.3 % of 32 × 32 views in `cos θ` and `φ`. Sampling takes every lobe's weight, a delta
/// lobe's included; a midpoint rule of `eval` over 32 × 32 incident cells takes the
/// glazed ceramics (GGX `α` 0.04) for 0.40 where they reflect 0.51, the chairs' plastic
/// (`α` 0.14) 2 % dark and a polished metal (`α` 0.0075) for 0.03 where it reflects 0.52
/// — and small glossy elements, which get no tile, pass on this albedo.
fn bihemispherical_albedo(p: &SurfaceParams) -> Vec3 {
    let bsdf = Bsdf::new(p);
    let sum: Vec3 = (0..VIEWS)
        .map(|k| {
            let cos = ((k as f32 + 0.5) / VIEWS as f32).sqrt();
            reflected_albedo(
                &bsdf,
                Vec3::new((1.0 - cos * cos).max(0.0).sqrt(), 0.0, cos),
            )
        })
        .sum();
    sum / VIEWS as f32
}

/// What a ray sees at a hit: the surface's parameters and whether it is a delta.
pub struct SurfaceHit {
    pub hit: Hit,
    pub params: SurfaceParams,
    pub position: Vec3,
    pub normal: Vec3,
    pub shading_normal: Vec3,
    pub delta: bool,
    /// Emission towards the ray (zero from the back of a one-sided emitter).
    pub emitted: Vec3,
}

impl SurfaceHit {
    /// The point as the direct light per pixel takes it, seen from direction `wo` (unit,
    /// away from the surface) through delta surfaces that let `weight` through: its
    /// estimates all taken at the point ([`DirectPoint::span`] zero), nothing else of
    /// its lookup known yet.
    pub fn direct_point(&self, wo: Vec3, weight: Vec3) -> DirectPoint {
        DirectPoint {
            triangle: self.hit.triangle,
            position: self.position,
            normal: self.normal,
            shading_normal: self.shading_normal,
            wo,
            bsdf: Bsdf::new(&self.params),
            weight,
            albedo: Vec3::ZERO,
            surfaces: Vec3::ZERO,
            reflected: None,
            span: [Vec3::ZERO; 2],
            gathered: false,
        }
    }
}

/// The surface at barycentrics `(u, v)` of `triangle` (an element's centre), seen from
/// no particular direction (emission counts only on a double-sided emitter's side).
pub fn seen_at(scene: &Scene, triangle: u32, u: f32, v: f32) -> SurfaceHit {
    let hit = Hit {
        triangle,
        t: 0.0,
        u,
        v,
    };
    seen(&scene.statics(), hit, Vec3::ZERO)
}

/// The surface at `hit` seen along `dir` (on a moving object where `placed` puts it).
pub fn seen(placed: &PlacedScene, hit: Hit, dir: Vec3) -> SurfaceHit {
    let sp = placed.surface(&hit);
    let scene = placed.scene();
    let material = &scene.materials[sp.material as usize];
    let params = material.params(&scene.textures, sp.uv);
    let towards_viewer = sp.geometric_normal.dot(dir) < 0.0;
    let emitted = if towards_viewer || material.double_sided {
        params.emission
    } else {
        Vec3::ZERO
    };
    SurfaceHit {
        hit,
        delta: Bsdf::new(&params).is_pure_delta(),
        params,
        position: sp.position,
        normal: sp.geometric_normal,
        shading_normal: sp.shading_normal,
        emitted,
    }
}

/// The side of a triangle a ray travelling along `dir` arrives on: 0 front, 1 back.
pub fn side_facing(normal: Vec3, dir: Vec3) -> u32 {
    u32::from(normal.dot(dir) > 0.0)
}

/// A direction a delta surface sends light on, with the weight it carries.
pub type Branch = (Vec3, Vec3);

/// The directions a delta surface sends a ray arriving along `dir` on, with the weight
/// each carries: the stronger branch first. Glass both reflects and refracts; the light
/// field follows the stronger branch to a diffuse surface, and the weaker one only for
/// the light it shows directly (a lamp's highlight on a glass sphere, the sky in a
/// window's reflection), so each pixel and line needs one lookup.
pub fn delta_step(s: &SurfaceHit, dir: Vec3) -> Option<(Branch, Option<Branch>)> {
    let p = &s.params;
    let n = s.shading_normal;
    let wo = -dir;
    let cos = n.dot(wo);
    let metal = p.metallic;
    let glass = (1.0 - metal) * p.transmission;
    let mirror = fresnel::reflect(wo, n).normalize();
    let metal_r = fresnel::schlick(p.base_color, Vec3::ONE, cos.abs()) * metal;
    let r = fresnel::dielectric(cos, p.ior.max(1.0001));
    let reflected = (mirror, metal_r + Vec3::splat(glass * r));
    let refracted = fresnel::refract(wo, n, p.ior.max(1.0001))
        .map(|(wi, _)| (wi.normalize(), p.base_color * glass * (1.0 - r)))
        .filter(|(_, t)| t.max_element() > 0.0);
    let reflects = reflected.1.max_element() > 0.0;
    match refracted {
        Some(t) if t.1.element_sum() > reflected.1.element_sum() => {
            Some((t, reflects.then_some(reflected)))
        }
        Some(t) if reflects => Some((reflected, Some(t))),
        Some(t) => Some((t, None)),
        None if reflects => Some((reflected, None)),
        None => None,
    }
}

/// GGX `α` below which a glossy surface too small for a tile is drawn as the mirror of
/// what it reflects ([`mirrored_gloss`]).
pub const MIRRORED_ALPHA: f32 = 0.25;

/// Whether the view draws a surface with `params` that has no tile as the mirror of what
/// it reflects: an opaque surface with a reflecting lobe (a metal, or a dielectric with a
/// specular layer) narrower than [`MIRRORED_ALPHA`] (its reflection blurred by under 30°,
/// `2α`: seen directly, the blur is the lobe's own, from a few directions drawn from it;
/// beyond a mirror or glass it is left out). Its reflecting
/// lobes' share
/// ([`Bsdf::specular_reflectance`]) goes on along the mirrored ray, its Lambertian base's
/// ([`Bsdf::diffuse_reflectance`]) is the light field's at the surface itself, and the sun's
/// and punctual lights' highlights on it are its BSDF's ([`highlights`]: the mirrored ray
/// would find the sun's disc in a pixel or two and a punctual light never); the per-pixel
/// direct light is taken where the mirrored ray lands. Drawn diffuse, such a surface shows
/// its irradiance times its albedo whatever its mirror direction sees: the breakfast
/// room's chrome chair legs (α 0.03), too thin for tiles, were grey where the path tracer
/// shows them mirroring the lit floor (its worst block, 44 % too dark); the black satin
/// apron of its table (α 0.17, cut into slivers smaller than a tile takes), which mirrors
/// the dark underside of the table top, five times too bright (half the image's relative
/// MSE); its glazed teapot and cups (a third metallic, α 0.04), which mirror the window,
/// a third as bright as the path tracer's. The bake keeps such a surface diffuse: it is
/// small, and what it sends on is little.
pub fn mirrored_gloss(params: &SurfaceParams) -> bool {
    let opaque = (1.0 - params.metallic) * params.transmission <= 0.0;
    let reflects = params.metallic > 0.0 || params.specular > 0.0;
    opaque
        && reflects
        && !Ggx::is_smooth(params.roughness)
        && Ggx::from_roughness(params.roughness).alpha < MIRRORED_ALPHA
}

/// The light of the sun (from its disc's centre: exact wherever the whole disc is seen)
/// and of every punctual light that `s` (its BSDF `bsdf`), seen along `dir`, reflects
/// towards the viewer, each behind a shadow ray through `scene`: a [`mirrored_gloss`]'s
/// highlights.
pub fn highlights(
    scene: &PlacedScene,
    lights: &Lights,
    s: &SurfaceHit,
    bsdf: &Bsdf,
    dir: Vec3,
) -> Vec3 {
    let wo = -dir;
    let frame = Frame::new(s.shading_normal);
    let sun = lights.sample_sun(Vec2::ZERO);
    let punctual = (0..lights.punctual.len()).filter_map(|i| lights.sample_punctual(i, s.position));
    sun.into_iter()
        .chain(punctual)
        .filter(|ls| s.normal.dot(ls.wi) * s.normal.dot(wo) > 0.0)
        .map(|ls| {
            let (f, _) = bsdf.eval(frame.to_local(wo), frame.to_local(ls.wi));
            let c = f * frame.n.dot(ls.wi).abs() * ls.contribution;
            let open = c.max_element() > 0.0
                && shadow_ray(&ls, s.position, s.normal)
                    .is_some_and(|(ray, tmax)| !scene.occluded(&ray, tmax));
            if open { c } else { Vec3::ZERO }
        })
        .sum()
}

/// A chain (its `weight`, `emitted` light and `deltas`) that ended at `s`, seen along
/// `dir`, continued along the mirror direction of `s`'s shading normal carrying
/// `reflectance` ([`mirrored_gloss`]); `None` past [`MAX_DELTA_DEPTH`].
pub fn mirrored(
    scene: &PlacedScene,
    (weight, emitted, deltas): (Vec3, Vec3, u32),
    s: &SurfaceHit,
    dir: Vec3,
    reflectance: Vec3,
    environment: &dyn Fn(Vec3) -> Vec3,
) -> Option<Chain> {
    if deltas >= MAX_DELTA_DEPTH || reflectance.max_element() <= 0.0 {
        return None;
    }
    let wi = fresnel::reflect(-dir, s.shading_normal).normalize();
    let rest = walk(
        scene,
        Ray::leaving(s.position, s.normal, wi),
        None,
        environment,
        MAX_DELTA_DEPTH - deltas - 1,
    );
    let reflected = weight * reflectance;
    Some(Chain {
        end: rest.end,
        weight: reflected * rest.weight,
        emitted: emitted + weight * s.emitted + reflected * rest.emitted,
        deltas: deltas + 1 + rest.deltas,
        beside: scaled(rest.beside, reflected),
    })
}

/// The first non-delta surface along `ray`, through at most [`MAX_DELTA_DEPTH`] delta
/// surfaces: what it is, the ray that reached it, the weight the deltas carried and the
/// light they let through on the way (emission of delta surfaces; the sky and sun when
/// the ray escapes, given by `environment`). `None` when the chain is cut off.
pub struct Chain {
    pub end: Option<(SurfaceHit, Ray)>,
    pub weight: Vec3,
    pub emitted: Vec3,
    /// Delta surfaces followed before the end.
    pub deltas: u32,
    /// The surfaces that glass's weaker branches on the way end on (not delta), each with
    /// the ray that reached it and the weight the way there carried: what they show is
    /// the viewer's to shade ([`crate::view::Visibility`] from the field's values), the
    /// chain's `emitted` holding only their emission.
    pub beside: Vec<(SurfaceHit, Ray, Vec3)>,
}

pub fn follow(scene: &PlacedScene, ray: Ray, environment: &dyn Fn(Vec3) -> Vec3) -> Chain {
    walk(scene, ray, None, environment, MAX_DELTA_DEPTH)
}

/// As [`follow`], with the ray's first hit already found (eye rays are cast in packets).
pub fn follow_from(
    scene: &PlacedScene,
    ray: Ray,
    first: Option<Hit>,
    environment: &dyn Fn(Vec3) -> Vec3,
) -> Chain {
    walk(scene, ray, Some(first), environment, MAX_DELTA_DEPTH)
}

/// The chain along `ray` from its first hit `first` where it ends there (a surface the
/// light field draws, or nothing); `None` where it goes on through a mirror or glass.
pub fn follow_first(
    scene: &PlacedScene,
    ray: Ray,
    first: Option<Hit>,
    environment: &dyn Fn(Vec3) -> Vec3,
) -> Option<Chain> {
    walk_with(
        scene,
        ray,
        Some(first),
        environment,
        MAX_DELTA_DEPTH,
        &mut |_| None,
    )
}

/// The chains of many rays at once, as [`follow_from`] makes each, with each ray's first
/// hit `firsts` found elsewhere and the hits of the rays past it (through mirrors and
/// glass) in the static scene found by `traced` in batches: each round walks every
/// unfinished chain again from its start with the hits found so far, up to the ray it
/// needs next, and traces those rays together (a mirror takes a round, a pane of glass
/// two: its reflection, then what lies beyond). The moving objects are tried here.
pub fn follow_all(
    scene: &PlacedScene,
    rays: &[Ray],
    firsts: &[Option<Hit>],
    environment: &(dyn Fn(Vec3) -> Vec3 + Sync),
    traced: &dyn StaticRays,
) -> Vec<Chain> {
    let mut found: Vec<Vec<Option<Hit>>> = vec![Vec::new(); rays.len()];
    let mut chains: Vec<Option<Chain>> = (0..rays.len()).map(|_| None).collect();
    let mut open: Vec<usize> = (0..rays.len()).collect();
    while !open.is_empty() {
        let walked: Vec<Result<Chain, Ray>> = open
            .par_iter()
            .map(|&i| {
                let mut answers = found[i].iter();
                let mut needed = None;
                let mut next = |r: &Ray| match answers.next() {
                    Some(h) => Some(scene.objects_closest_hit(r, f32::INFINITY, *h)),
                    None => {
                        needed = Some(*r);
                        None
                    }
                };
                let chain = walk_with(
                    scene,
                    rays[i],
                    Some(firsts[i]),
                    environment,
                    MAX_DELTA_DEPTH,
                    &mut next,
                );
                chain.ok_or_else(|| needed.expect("a walk stops only for a ray"))
            })
            .collect();
        let mut asked = Vec::new();
        let mut still = Vec::new();
        for (&i, w) in open.iter().zip(walked) {
            match w {
                Ok(c) => chains[i] = Some(c),
                Err(r) => {
                    asked.push(r);
                    still.push(i);
                }
            }
        }
        if asked.is_empty() {
            break;
        }
        let hits = traced.closest_hits(&asked);
        // A hit missing from the answers counts as a miss: every round moves each walk on.
        for (k, &i) in still.iter().enumerate() {
            found[i].push(hits.get(k).copied().flatten());
        }
        open = still;
    }
    chains
        .into_iter()
        .map(|c| c.expect("every walk finished"))
        .collect()
}

fn walk(
    scene: &PlacedScene,
    ray: Ray,
    first: Option<Option<Hit>>,
    environment: &dyn Fn(Vec3) -> Vec3,
    depth: u32,
) -> Chain {
    let mut next = |r: &Ray| Some(scene.closest_hit(r, f32::INFINITY));
    walk_with(scene, ray, first, environment, depth, &mut next)
        .expect("the scene answers every ray")
}

/// The chain along `ray` (its first hit `first` where known), every further ray's
/// closest hit given by `next`; `None` as soon as `next` has none.
fn walk_with(
    scene: &PlacedScene,
    mut ray: Ray,
    mut first: Option<Option<Hit>>,
    environment: &dyn Fn(Vec3) -> Vec3,
    depth: u32,
    next: &mut dyn FnMut(&Ray) -> Option<Option<Hit>>,
) -> Option<Chain> {
    let mut weight = Vec3::ONE;
    let mut emitted = Vec3::ZERO;
    let mut beside = Vec::new();
    for level in 0..=depth {
        let hit = match first.take() {
            Some(h) => h,
            None => next(&ray)?,
        };
        let Some(hit) = hit else {
            emitted += weight * environment(ray.dir);
            return Some(Chain {
                end: None,
                weight,
                emitted,
                deltas: level,
                beside,
            });
        };
        let s = seen(scene, hit, ray.dir);
        if !s.delta {
            return Some(Chain {
                end: Some((s, ray)),
                weight,
                emitted,
                deltas: level,
                beside,
            });
        }
        emitted += weight * s.emitted;
        let Some(((wi, w), weaker)) = delta_step(&s, ray.dir) else {
            break;
        };
        if let Some((wj, wk)) = weaker
            && level < depth
        {
            // The weaker branch: only what it shows directly, with half the depth left
            // (so a chain of glass surfaces costs a bounded number of rays).
            let side = walk_with(
                scene,
                Ray::leaving(s.position, s.normal, wj),
                None,
                environment,
                (depth - level - 1) / 2,
                next,
            )?;
            let carried = weight * wk;
            let shown = side.emitted
                + side
                    .end
                    .as_ref()
                    .map_or(Vec3::ZERO, |(e, _)| side.weight * e.emitted);
            emitted += carried * shown;
            if let Some((e, r)) = side.end {
                beside.push((e, r, carried * side.weight));
            }
            beside.extend(scaled(side.beside, carried));
        }
        weight *= w;
        ray = Ray::leaving(s.position, s.normal, wi);
    }
    Some(Chain {
        end: None,
        weight: Vec3::ZERO,
        emitted,
        deltas: depth + 1,
        beside,
    })
}

/// `beside` with every weight times `by`.
fn scaled(mut beside: Vec<(SurfaceHit, Ray, Vec3)>, by: Vec3) -> Vec<(SurfaceHit, Ray, Vec3)> {
    for b in &mut beside {
        b.2 *= by;
    }
    beside
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(base: f32, metallic: f32, roughness: f32, specular: f32) -> SurfaceParams {
        SurfaceParams {
            base_color: Vec3::splat(base),
            metallic,
            roughness,
            emission: Vec3::ZERO,
            specular,
            specular_color: Vec3::ONE,
            transmission: 0.0,
            ior: 1.5,
        }
    }

    /// `(1/π) ∫∫ f cos θo cos θi` by a plain midpoint rule over both hemispheres with the
    /// BSDF's `eval` (independent of its sampling, which `diffuse_albedo` uses).
    fn brute_force(p: &SurfaceParams, n: usize) -> Vec3 {
        let bsdf = Bsdf::new(p);
        let dir = |i: usize, j: usize| {
            // Uniform in cos θ and φ: each cell has solid angle 2π/n².
            let c = (i as f32 + 0.5) / n as f32;
            let phi = (j as f32 + 0.5) / n as f32 * std::f32::consts::TAU;
            let s = (1.0 - c * c).sqrt();
            Vec3::new(s * phi.cos(), s * phi.sin(), c)
        };
        let cell = std::f32::consts::TAU / (n * n) as f32;
        let mut sum = Vec3::ZERO;
        for io in 0..n {
            for jo in 0..n {
                let wo = dir(io, jo);
                for ii in 0..n {
                    for ji in 0..n {
                        let wi = dir(ii, ji);
                        let (f, _) = bsdf.eval(wo, wi);
                        sum += f * wo.z * wi.z * cell * cell;
                    }
                }
            }
        }
        sum / std::f32::consts::PI
    }

    /// The albedo is the BSDF's: Lambert's exactly its base; rough dielectrics and metals
    /// as a quadrature of `eval` twice as fine in every direction gives them (48⁴ cells),
    /// within the coarser rule's error: 0.5 %. The normal-incidence formula it replaced,
    /// `base (1 − F0)² + F0`, is 7 % above the white walls' true value and fails this.
    #[test]
    fn albedo_is_the_bsdfs_bihemispherical_albedo() {
        // Lambert: the midpoint rule of cos θ over uniform cells of cos θ is exact, up to
        // the f32 sum of 256 × 1024 terms (measured 1e-6).
        let lambert = diffuse_albedo(&params(0.6, 0.0, 1.0, 0.0));
        assert!((lambert - 0.6).abs().max_element() < 1e-5, "{lambert}");
        // The breakfast room's white walls (WhiteMatt), a rough metal, a half-metal.
        for p in [
            params(0.9, 0.0, 0.968, 1.0),
            params(0.8, 0.0, 0.75, 1.0),
            params(0.9, 1.0, 0.9, 1.0),
            params(0.5, 0.5, 0.8, 1.0),
        ] {
            let got = diffuse_albedo(&p);
            let want = brute_force(&p, 48);
            eprintln!("{p:?}: albedo {got}, quadrature {want}");
            assert!(
                (got - want).abs().max_element() <= 0.005 * want.max_element(),
                "{p:?}: albedo {got}, quadrature {want}"
            );
            assert!(got.max_element() <= 1.0);
        }
    }

    /// A narrow lobe's albedo too, where a quadrature of `eval` cannot see it: a white
    /// metal (Schlick's `F` = 1 at every angle) reflects all the light its microfacets do
    /// not shadow, which for GGX `α` ≤ 0.04 is above 97 % (the single-scattering loss
    /// grows with `α`: under 3 % at these). The glazed ceramics' lobe (`α` 0.04) and a
    /// polished metal's (`α` 0.0075): 0.994 and 0.9999; a midpoint rule of 32 × 32
    /// incident cells took them for 0.62 and 0.064.
    #[test]
    fn a_narrow_lobes_albedo_is_all_it_reflects() {
        for roughness in [0.2, 0.0865] {
            let white_metal = diffuse_albedo(&params(1.0, 1.0, roughness, 1.0));
            assert!(
                white_metal.min_element() > 0.97 && white_metal.max_element() <= 1.0,
                "roughness {roughness}: {white_metal}"
            );
        }
    }

    /// The albedo towards a view is the BSDF's directional albedo there: Lambert's its base
    /// at every view; a rough dielectric's and metal's as a quadrature of `eval` over the
    /// incident hemisphere gives it (96² cells, within 1 % at every tabulated view: the
    /// table's 4096 samples a step and its linear steps); and its cosine-weighted mean over
    /// the views is the bihemispherical albedo the light field passes on (so drawing each
    /// view with its own takes nothing from the field's energy, it only shares it out
    /// among the views). Drawn with the mean instead, the breakfast room's floor, seen
    /// near grazing, was 7.7 % too bright and its walls 2.6 % too dark.
    #[test]
    fn albedo_towards_a_view_is_the_bsdfs_directional_albedo() {
        let lambert = params(0.6, 0.0, 1.0, 0.0);
        for c in [0.05, 0.3, 0.7, 1.0] {
            let a = albedo_towards(&lambert, c);
            assert!((a - 0.6).abs().max_element() < 1e-4, "cos {c}: {a}");
        }
        let n = 96;
        let incident = |bsdf: &Bsdf, wo: Vec3| {
            let cell = std::f32::consts::TAU / (n * n) as f32;
            let mut sum = Vec3::ZERO;
            for k in 0..n * n {
                let c = ((k / n) as f32 + 0.5) / n as f32;
                let phi = ((k % n) as f32 + 0.5) / n as f32 * std::f32::consts::TAU;
                let r = (1.0 - c * c).sqrt();
                let wi = Vec3::new(r * phi.cos(), r * phi.sin(), c);
                sum += bsdf.eval(wo, wi).0 * c * cell;
            }
            sum
        };
        for p in [
            params(0.9, 0.0, 0.968, 1.0),
            params(0.7, 0.0, 0.83, 1.0),
            params(0.9, 1.0, 0.9, 1.0),
        ] {
            let bsdf = Bsdf::new(&p);
            let (mut mean, views) = (Vec3::ZERO, 64);
            for v in 0..views {
                let c = (v as f32 + 0.5) / views as f32;
                mean += albedo_towards(&p, c) * 2.0 * c / views as f32;
            }
            for k in [3, 10, 20, 28, 31] {
                let wo = at_cos(k, TOWARDS_STEPS).max(Vec3::new(0.0, 0.0, 1e-3));
                let (got, want) = (albedo_towards(&p, wo.z), incident(&bsdf, wo));
                assert!(
                    (got - want).abs().max_element() <= 0.01 * want.max_element(),
                    "{p:?} at cos {}: {got} against the quadrature's {want}",
                    wo.z
                );
            }
            let field = diffuse_albedo(&p);
            eprintln!("{p:?}: mean over views {mean}, bihemispherical {field}");
            assert!(
                (mean - field).abs().max_element() <= 0.01 * field.max_element(),
                "{p:?}: the views' mean {mean}, the field's albedo {field}"
            );
        }
    }
}
