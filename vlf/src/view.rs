//! Drawing the light field from a viewpoint (§4 of the paper): for each pixel, what the
//! eye sees — found by a ray cast through the pixel, continued exactly through mirrors
//! and smooth glass (the paper's recursive rendering of specular faces) — and the baked
//! irradiance there, interpolated between element centres. No shadow rays and no
//! sampling: the cost per pixel does not depend on the lighting.
//!
//! Visibility gives each pixel a [`Lookup`]; the radiance is then
//! `emitted + weight · E(base, res, u, v)` with `E` the baked irradiance interpolated by
//! [`crate::elements::interpolate`], or, where the eye sees a glossy element,
//! `emitted + weight · L(tile, x, y)` with `L` its tile's radiance interpolated between
//! bins ([`crate::octahedral::interpolate`]) in the direction towards the eye
//! ([`Tiles::view_coords`]). The render node does the second step on the GPU
//! (`render-node/src/cache/shade_field.wgsl`), [`shade`] on the CPU; both read one array of
//! values, the elements' irradiance followed by the tiles' radiance
//! ([`crate::State::values`]).

use std::ops::Range;
use std::sync::{Arc, OnceLock, RwLock};

use glam::{Vec2, Vec3};
use holocave_cave::WallView;
use holocave_scene::bvh::PACKET;
use holocave_scene::{Hit, PlacedScene, Placement, Ray, Scene};
use holocave_tracer::bsdf::Bsdf;
use holocave_tracer::film::Image;
use holocave_tracer::frame::Frame;
use holocave_tracer::fresnel;
use holocave_tracer::lights::Lights;
use rayon::prelude::*;

use crate::StaticRays;
use crate::bake::{environment, sky};
use crate::caustics::Caustics;
use crate::elements::{Elements, bilinear_cells, interpolate};
use crate::footprint::{Screen, pixel_span};
use crate::objects::ObjectLight;
use crate::octahedral;
use crate::pixel_direct::{DirectPoint, Estimate};
use crate::sequence::{R2, r_sequence};
use crate::surface::{
    Chain, SurfaceHit, albedo_towards, follow, follow_all, follow_first, follow_from, highlights,
    mirrored, mirrored_gloss, seen, side_facing,
};
use crate::tiles::Tiles;

/// Directions a frame a mirrored-gloss surface seen directly takes of its lobe
/// ([`Visibility::blurred_reflection`]).
pub const BLURRED_RAYS: u64 = 8;

/// Directions a frame a widened tile's surface takes of each of its two lobes
/// ([`Visibility::sharpened_reflection`]).
pub const SHARPENED_RAYS: u64 = 2;

/// The most frames of a still view whose glossy reflections' directions are averaged
/// ([`ReflectionFrames`]).
pub const AVERAGED_FRAMES: u32 = 32;

/// What one pixel (or one ray) sees of the light field.
/// Laid out as the render node's shader reads it (`Lookup` in
/// `render-node/src/cache/shade_field.wgsl`): uploaded as it is.
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct Lookup {
    /// First element of the side seen; `u32::MAX` when no diffuse surface is seen.
    pub base: u32,
    /// That triangle's resolution.
    pub res: u32,
    /// Barycentric coordinates of the point seen.
    pub u: f32,
    pub v: f32,
    /// `ρ/π` of the point times what delta surfaces on the way let through.
    pub weight: [f32; 3],
    /// Light reaching the eye along the way: emitters, the sky, the sun.
    pub emitted: [f32; 3],
    /// First entry of the glossy tile seen (its bins follow); `u32::MAX` when none. Then
    /// `weight` is what delta surfaces on the way let through, and `base` is `u32::MAX`.
    pub tile: u32,
    /// The tile's bins along each side (`k`).
    pub bins: u32,
    /// Map coordinates in the tile of the direction towards the eye (`[0, k]²`).
    pub x: f32,
    pub y: f32,
    /// How much the render cache's samples count here: 1, or 0 where a moving object
    /// changes what the static caches hold (the object itself, its shadows, its
    /// surroundings), so the pixel shows this lookup's light alone; under a display's
    /// measured prior, scaled by how far the pixel's direct light has converged.
    pub samples: f32,
    /// The moving object the point seen lies on (its index + 1; 0: the static scene).
    /// The render cache's samples count only from a point on the same one, so that a
    /// point left behind by a moving object, or one of the room seen where the object now
    /// stands, is never blended in.
    pub object: u32,
}

impl Lookup {
    pub const NONE: Lookup = Lookup {
        base: u32::MAX,
        res: 1,
        u: 0.0,
        v: 0.0,
        weight: [0.0; 3],
        emitted: [0.0; 3],
        tile: u32::MAX,
        bins: 1,
        x: 0.0,
        y: 0.0,
        samples: 1.0,
        object: 0,
    };
}

/// The light arriving at a point along one direction that the per-pixel direct light does
/// not give ([`Visibility::arriving`]).
pub struct Arriving {
    pub radiance: Vec3,
    /// The lookup it was shaded from.
    pub lookup: Lookup,
    /// The non-delta static point it comes from: the per-pixel pass would add its direct
    /// light.
    pub point: Option<DirectPoint>,
    /// Set when the ray ends on an emitter over exactly one delta surface (a mirror when
    /// the tracer samples lights through it).
    pub over_mirror: Option<OverMirror>,
    /// The part of `radiance` that is an emitter or the sun's disc seen through mirrors
    /// and glass: the caustics, where the walls take them per pixel
    /// ([`Visibility::caustic_light`]).
    pub caustic: Vec3,
}

/// An emitter seen over one delta surface: that part of [`Arriving::radiance`], and the
/// path's geometry, for weighing it against next-event estimation through mirrors.
pub struct OverMirror {
    pub emitted: Vec3,
    /// The delta surface's triangle and its distance from the point.
    pub mirror: u32,
    pub to_mirror: f32,
    /// The emitter's triangle, its unit face normal, the direction from the mirror and
    /// the distance beyond it.
    pub emitter: u32,
    pub normal: Vec3,
    pub dir: Vec3,
    pub beyond: f32,
}

/// The share of a static element's cosine-weighted hemisphere the moving objects take
/// (as [`ObjectLight::openness`] reckons it) beyond which the per-pixel pass gathers what
/// they change of its indirect light instead of darkening the field's by that share: the
/// darkening assumes the light arrives evenly, and beside an object that hides a window
/// from the floor it left the floor 25 % too bright, in a corner the walls 35 % too dark
/// (the room's block, against the path tracer; `docs/usage/objects.md`).
pub const GATHERED_OCCLUSION: f32 = 0.04;

/// The values a view's lookups are shaded with, and whether they are the remainder under
/// the direct light per pixel ([`Visibility::draw_with`]).
type Drawn = (Arc<Vec<[f32; 3]>>, bool);

/// The scene's side of drawing: the element layout, the light the eye sees directly, and
/// where the moving objects are ([`crate::objects`]).
pub struct Visibility {
    scene: Arc<Scene>,
    elements: Elements,
    tiles: Tiles,
    lights: Lights,
    objects: RwLock<ObjectLight>,
    /// The light field's values (all of its light): what the objects' probes gather and
    /// what the glossy surfaces drawn as mirrors reflect ([`Visibility::light_objects`]).
    light: OnceLock<Arc<Vec<[f32; 3]>>>,
    /// The values the lookups are shaded with, where the CPU shades a part of a lookup
    /// itself, and whether they are the remainder under the direct light per pixel
    /// ([`Visibility::draw_with`]).
    drawn: RwLock<Option<Drawn>>,
    /// Whether the objects darken the light field's part near them (off only to measure
    /// what that does: [`Visibility::without_darkening`]).
    darkening: bool,
    /// The caustics, taken per pixel with the direct light ([`Visibility::draw_caustics`]).
    caustics: OnceLock<Arc<Caustics>>,
}

/// The frames of a still view whose directions of each glossy lobe the lookups take: a
/// view's frames take each lobe's sequence on, so that their mean is that of all their
/// directions ([`DirectPoint::reflected`]). [`BLURRED_RAYS`] a frame for a surface drawn
/// as its mirror ([`Visibility::blurred_reflection`]), always; [`SHARPENED_RAYS`] a frame
/// of each of a widened tile's two lobes ([`Visibility::sharpened_reflection`]), none
/// where `sharpened` is empty: a view's first frame, and a still view's frames after
/// [`AVERAGED_FRAMES`], whose mean the walls keep (the sharpening doubles the frame of a
/// wall that sees only such a floor; in motion the tile's reflection is shown).
#[derive(Clone, Debug, PartialEq)]
pub struct ReflectionFrames {
    pub blurred: Range<u64>,
    pub sharpened: Range<u64>,
}

impl ReflectionFrames {
    /// Frame `n` of a view that has not moved since frame 0.
    pub fn still(n: u64) -> ReflectionFrames {
        let sharpened = if (1..=u64::from(AVERAGED_FRAMES)).contains(&n) {
            n..n + 1
        } else {
            0..0
        };
        ReflectionFrames {
            blurred: n..n + 1,
            sharpened,
        }
    }

    /// Every frame's of a still view after `frames` frames ([`Self::still`] of each),
    /// up to [`AVERAGED_FRAMES`] of each kind.
    pub fn after(frames: u32) -> ReflectionFrames {
        let frames = u64::from(frames.max(1));
        let most = u64::from(AVERAGED_FRAMES);
        ReflectionFrames {
            blurred: 0..frames.min(most),
            sharpened: 1..frames.min(most + 1),
        }
    }

    /// The indices in a mirror-drawn surface's lobe sequence of these frames' directions.
    fn blurred_rays(&self) -> Range<u64> {
        self.blurred.start * BLURRED_RAYS..self.blurred.end * BLURRED_RAYS
    }

    /// The same for each of a widened tile's two lobes.
    fn sharpened_rays(&self) -> Range<u64> {
        self.sharpened.start * SHARPENED_RAYS..self.sharpened.end * SHARPENED_RAYS
    }
}

impl Visibility {
    /// The objects start at rest, unlit until [`Visibility::light_objects`].
    pub fn new(scene: Arc<Scene>, elements: Elements, tiles: Tiles) -> Self {
        let lights = Lights::new(&scene);
        Visibility {
            objects: RwLock::new(ObjectLight::at_rest(&scene)),
            darkening: true,
            scene,
            elements,
            tiles,
            lights,
            light: OnceLock::new(),
            drawn: RwLock::new(None),
            caustics: OnceLock::new(),
        }
    }

    /// Takes the caustics per pixel from `caustics` wherever the direct light is (the
    /// remainder drawn then leaves the field's part out: [`crate::split::Split`]).
    pub fn draw_caustics(&self, caustics: Arc<Caustics>) {
        let _ = self.caustics.set(caustics);
    }

    /// Whether the caustics are taken per pixel ([`Visibility::draw_caustics`]).
    pub fn caustics_per_pixel(&self) -> bool {
        self.caustics.get().is_some()
    }

    /// The caustics' light towards the eye of lookup `l`, whose point is `p`: its weight
    /// (`ρ/π` and what the delta surfaces on the way let through) times the irradiance
    /// the photons bring there, where it sees an element (a glossy tile keeps its own);
    /// averaged over the pixel's footprint where the point is seen straight from the
    /// eye of `screen` (through mirrors and glass the footprint is not known).
    pub fn caustic_light(&self, l: &Lookup, p: &DirectPoint, screen: Option<&Screen>) -> Vec3 {
        match self.caustics.get() {
            Some(c) if l.base != u32::MAX => {
                let straight = p.weight == Vec3::ONE;
                // A pixel's area as an ellipse's: half-axes 1/√π of its sides.
                let footprint = screen
                    .filter(|_| straight)
                    .map(|s| s.footprint(p, std::f32::consts::PI.sqrt().recip()));
                Vec3::from(l.weight) * c.irradiance(p.position, p.normal, footprint)
            }
            _ => Vec3::ZERO,
        }
    }

    /// The same without the moving objects' darkening of the light field near them (to
    /// measure its effect; the walls always darken).
    pub fn without_darkening(mut self) -> Self {
        self.darkening = false;
        self
    }

    /// Lights the moving objects, and the reflections of the glossy surfaces drawn as
    /// mirrors ([`Self::blurred_reflection`]), from the light field's `values` (all of its
    /// light: [`crate::State::values`]); the first call counts.
    pub fn light_objects(&self, values: Arc<Vec<[f32; 3]>>) {
        if self.light.set(values).is_err() || self.scene.objects().is_empty() {
            return;
        }
        let mut o = self.objects.write().unwrap_or_else(|e| e.into_inner());
        let at = o.placements.clone();
        let values = self.light.get().expect("set above");
        o.place(&self.scene, &at, Some(&|p, d| self.incoming(p, d, values)));
    }

    /// The values the lookups made from now on are shaded with (the light field's, all of
    /// it or, with `remainder`, what the direct light per pixel leaves): a glossy surface
    /// drawn as its mirror ([`mirrored_gloss`]) takes its Lambertian base's light from
    /// them at the surface itself. Until given, a surface with a Lambertian base is drawn
    /// diffuse and only a pure metal as its mirror.
    pub fn draw_with(&self, values: Arc<Vec<[f32; 3]>>, remainder: bool) {
        *self.drawn.write().unwrap_or_else(|e| e.into_inner()) = Some((values, remainder));
    }

    /// Copies `ranges` of `values` into the values given to [`Self::draw_with`]: the
    /// gathers kept in the field's elements ([`crate::kept_gathers`]), which the lookups
    /// shaded on the GPU read there and a mirror-drawn surface's base reads here.
    pub fn update_drawn(&self, values: &[[f32; 3]], ranges: &[std::ops::Range<usize>]) {
        let mut drawn = self.drawn.write().unwrap_or_else(|e| e.into_inner());
        if let Some((v, _)) = drawn.as_mut() {
            let v = Arc::make_mut(v);
            for r in ranges {
                v[r.clone()].copy_from_slice(&values[r.clone()]);
            }
        }
    }

    /// Runs `f` with the values given to [`Self::draw_with`], if any, and whether the
    /// per-pixel pass adds the direct light at the points.
    pub(crate) fn with_drawn<T>(&self, f: impl FnOnce(Option<&[[f32; 3]]>, bool) -> T) -> T {
        let drawn = self.drawn.read().unwrap_or_else(|e| e.into_inner());
        match drawn.as_ref() {
            Some((values, remainder)) => f(Some(values.as_slice()), *remainder),
            None => f(None, false),
        }
    }

    /// The irradiance moving object `k`'s probe gives a surface of unit normal `n` on it
    /// ([`ObjectLight::irradiance`]).
    pub fn object_irradiance(&self, k: usize, n: Vec3) -> Vec3 {
        let o = self.objects.read().unwrap_or_else(|e| e.into_inner());
        o.irradiance(k, n)
    }

    /// Where the moving objects stand now.
    pub fn placements(&self) -> Vec<Placement> {
        let o = self.objects.read().unwrap_or_else(|e| e.into_inner());
        o.placements.clone()
    }

    /// Puts the moving objects at `placements` (one per object of the scene); returns
    /// whether any moved.
    pub fn place_objects(&self, placements: &[Placement]) -> bool {
        let mut o = self.objects.write().unwrap_or_else(|e| e.into_inner());
        match self.light.get() {
            Some(values) => o.place(
                &self.scene,
                placements,
                Some(&|p, d| self.incoming(p, d, values)),
            ),
            None => o.place(&self.scene, placements, None),
        }
    }

    /// The radiance arriving at `at` from direction `dir` that the per-pixel direct light
    /// does not give: what the static surfaces there send back (from the light field's
    /// `values`) and the sky, without emitters and the sun seen directly (with those seen
    /// through mirrors and glass, where shadow rays do not reach).
    pub fn incoming(&self, at: Vec3, dir: Vec3, values: &[[f32; 3]]) -> Vec3 {
        self.arriving(at, dir, values).radiance
    }

    /// [`Self::incoming`], with where it comes from.
    pub fn arriving(&self, at: Vec3, dir: Vec3, values: &[[f32; 3]]) -> Arriving {
        let ray = Ray::new(at, dir);
        self.arriving_from(ray, self.scene.closest_hit(&ray, f32::INFINITY), values)
    }

    /// [`Self::arriving`] along `ray`, whose first hit in the static scene, `first`, was
    /// found elsewhere (a batch of rays on the GPU).
    pub fn arriving_from(&self, ray: Ray, first: Option<Hit>, values: &[[f32; 3]]) -> Arriving {
        self.arriving_among(ray, first, values, &ObjectLight::default())
    }

    /// [`Self::arriving_from`] with the field's part at the surface the ray ends on
    /// darkened by the moving objects where they stand ([`ObjectLight::openness`]): what a
    /// gather from beside an object sees of the floor the object shades
    /// ([`crate::object_gather`]).
    pub fn arriving_darkened(&self, ray: Ray, first: Option<Hit>, values: &[[f32; 3]]) -> Vec3 {
        let objects = self.objects.read().unwrap_or_else(|e| e.into_inner());
        self.arriving_among(ray, first, values, &objects).radiance
    }

    fn arriving_among(
        &self,
        ray: Ray,
        first: Option<Hit>,
        values: &[[f32; 3]],
        objects: &ObjectLight,
    ) -> Arriving {
        // Shadow rays stop at mirrors and glass: the emitters and the sun seen through
        // them come along this ray instead.
        let statics = self.scene.statics();
        let dir = ray.dir;
        let chain = follow_from(&statics, ray, first, &environment(&self.lights));
        // What a surface drawn as its mirror shows (its highlights and base, the sky and
        // emitters in it) arrives as what a delta surface shows does: next-event
        // estimation at `at` takes none of it.
        let behind_delta = chain.deltas > 0
            || (chain.end.as_ref())
                .is_some_and(|(s, r)| self.drawn_as_mirror(s, r.dir, Some(values)));
        let over_mirror = match (&chain.end, first) {
            (Some((s, r)), Some(m)) if chain.deltas == 1 && s.emitted.max_element() > 0.0 => {
                Some(OverMirror {
                    emitted: chain.weight * s.emitted,
                    mirror: m.triangle,
                    to_mirror: m.t,
                    emitter: s.hit.triangle,
                    normal: s.normal,
                    dir: r.dir,
                    beyond: s.hit.t,
                })
            }
            _ => None,
        };
        // The caustics the photon map holds: an emitter, or the sun's disc, seen through
        // mirrors and glass (the sun's found by walking again with the sky alone).
        let caustic = match &chain.end {
            Some((s, _)) if chain.deltas > 0 => chain.weight * s.emitted,
            None if chain.deltas > 0 && self.lights.sun.is_some() => {
                let sky_alone = |d: Vec3| sky(&self.lights, d);
                chain.emitted - follow_from(&statics, ray, first, &sky_alone).emitted
            }
            _ => Vec3::ZERO,
        };
        // Straight out of the scene: the sky only (the sun comes by next-event
        // estimation); onto a surface: not its emission (the emitters come so too).
        let escaped = chain.end.is_none();
        let first_frame = ReflectionFrames::still(0);
        let drawn = (Some(values), false, &first_frame);
        let (mut l, point) = self.lookup_chain(chain, objects, None, drawn);
        if !behind_delta {
            l.emitted = if escaped {
                sky(&self.lights, dir)
            } else {
                Vec3::ZERO
            }
            .to_array();
        }
        Arriving {
            radiance: shade_one(&l, values),
            lookup: l,
            point,
            over_mirror,
            caustic,
        }
    }

    /// The visibility of a bake of `scene` with `settings`: its element layout and tiles.
    pub fn of(scene: Arc<Scene>, settings: &crate::Settings) -> Self {
        let elements = crate::layout(&scene, settings);
        let tiles = crate::tiles(&scene, settings, &elements);
        Visibility::new(scene, elements, tiles)
    }

    /// The scene drawn.
    pub fn scene(&self) -> &Arc<Scene> {
        &self.scene
    }

    /// The element layout.
    pub fn elements(&self) -> &Elements {
        &self.elements
    }

    /// The glossy tiles (none for a scene without glossy surfaces).
    pub fn tiles(&self) -> &Tiles {
        &self.tiles
    }

    /// What `ray` sees.
    pub fn lookup(&self, ray: Ray) -> Lookup {
        self.lookup_and_point(ray).0
    }

    /// What `ray` sees in a view's first frame, and the non-delta point it ends on for the
    /// per-pixel direct light ([`crate::pixel_direct`]).
    pub fn lookup_and_point(&self, ray: Ray) -> (Lookup, Option<DirectPoint>) {
        let static_hit = self.scene.closest_hit(&ray, f32::INFINITY);
        let (l, p, _) = self.lookup_point_and_hit(ray, static_hit, &ReflectionFrames::still(0));
        (l, p)
    }

    /// [`Self::lookup_and_point`], and the ray's first hit (mirrors and glass included):
    /// the surface a sample along this ray belongs to; `static_hit` is the ray's first hit
    /// in the static scene, found elsewhere (a batch of rays on the GPU), and the moving
    /// objects are tried here; the glossy lobes take the directions of `frames`.
    pub fn lookup_point_and_hit(
        &self,
        ray: Ray,
        static_hit: Option<Hit>,
        frames: &ReflectionFrames,
    ) -> (Lookup, Option<DirectPoint>, Option<Hit>) {
        let env = environment(&self.lights);
        let objects = self.objects.read().unwrap_or_else(|e| e.into_inner());
        let placed = self.scene.placed(&objects.placements);
        let first = placed.objects_closest_hit(&ray, f32::INFINITY, static_hit);
        let chain = follow_from(&placed, ray, first, &env);
        let (l, p) = self
            .with_drawn(|v, d| self.lookup_chain(chain, &objects, Some(&placed), (v, d, frames)));
        (l, p, first)
    }

    /// Where `ray` first meets, at `first` (a static hit), a surface drawn as its mirror
    /// ([`Self::drawn_as_mirror`]) whose Lambertian base reflects: the elements the base's
    /// light is interpolated from there, with their weights, and what the base sends
    /// towards the eye per unit of their irradiance, `ρ_d(cos θ_o) / π` — what a gather
    /// there keeps in the field ([`crate::gather`]).
    pub fn mirrored_base(&self, ray: &Ray, first: Option<Hit>) -> Option<([(u32, f32); 4], Vec3)> {
        let hit = first?;
        let s = self.with_placed(|placed| {
            placed
                .object_of(hit.triangle)
                .is_none()
                .then(|| seen(placed, hit, ray.dir))
        })?;
        let drawn = self.with_drawn(|v, _| self.drawn_as_mirror(&s, ray.dir, v));
        let cos_o = s.shading_normal.dot(ray.dir).abs();
        let weight = Bsdf::new(&s.params).diffuse_reflectance(cos_o) * std::f32::consts::FRAC_1_PI;
        if !drawn || weight.min_element() <= 0.0 {
            return None;
        }
        let cells = self.elements.triangles[hit.triangle as usize];
        let side = side_facing(s.normal, ray.dir);
        Some((
            bilinear_cells(cells.base(side), cells.res, hit.u, hit.v),
            weight,
        ))
    }

    /// What glows along `ray` through `placed` as the walls draw it — the emitters and
    /// the sky seen directly or through mirrors and glass, what a lookup's `emitted`
    /// holds before the direct light — and whether the ray ends on a surface that does
    /// not glow, whose light is a lookup's element or tile part
    /// ([`crate::glow_edges`]).
    pub fn glow_along(&self, placed: &PlacedScene, ray: Ray) -> (Vec3, bool) {
        let chain = follow(placed, ray, &environment(&self.lights));
        match &chain.end {
            Some((s, _)) => (
                chain.emitted + chain.weight * s.emitted,
                s.emitted.max_element() <= 0.0,
            ),
            None => (chain.emitted, false),
        }
    }

    /// What the surfaces that glass's weaker branches end on ([`Chain::beside`]) show,
    /// from the field's values (all of its light: [`Visibility::light_objects`]), where
    /// each is a diffuse element of the static scene: the reflection of the room in a
    /// glass sphere, which near its rim is as strong as what it lets through. Nothing
    /// before the field's values are set.
    fn beside_light(
        &self,
        beside: &[(SurfaceHit, Ray, Vec3)],
        placed: Option<&PlacedScene>,
    ) -> Vec3 {
        let Some(total) = self.light.get() else {
            return Vec3::ZERO;
        };
        // A weight below a thousandth shows nothing an 8-bit pixel holds.
        (beside.iter())
            .filter(|(s, _, w)| {
                w.max_element() >= 1e-3
                    && placed.is_none_or(|p| p.object_of(s.hit.triangle).is_none())
                    && (s.hit.triangle as usize) < self.elements.triangles.len()
            })
            .map(|(s, r, weight)| {
                let side = side_facing(s.normal, r.dir);
                let element = self
                    .elements
                    .element(s.hit.triangle, side, s.hit.u, s.hit.v);
                if self.tiles.of(element).is_some() || mirrored_gloss(&s.params) {
                    return Vec3::ZERO;
                }
                let cells = self.elements.triangles[s.hit.triangle as usize];
                let irradiance = interpolate(total, cells.base(side), cells.res, s.hit.u, s.hit.v);
                *weight
                    * albedo_towards(&s.params, s.shading_normal.dot(r.dir))
                    * std::f32::consts::FRAC_1_PI
                    * irradiance
            })
            .sum()
    }

    /// Runs `f` with the scene as this frame places its moving objects.
    pub fn with_placed<T>(&self, f: impl FnOnce(&PlacedScene) -> T) -> T {
        let objects = self.objects.read().unwrap_or_else(|e| e.into_inner());
        f(&self.scene.placed(&objects.placements))
    }

    /// Whether the static surface `s`, reached along `dir`, is drawn as the mirror of what
    /// it reflects: a glossy surface without a tile ([`mirrored_gloss`]) whose Lambertian
    /// base, if it has one, can be shaded from `values`.
    fn drawn_as_mirror(&self, s: &SurfaceHit, dir: Vec3, values: Option<&[[f32; 3]]>) -> bool {
        let side = side_facing(s.normal, dir);
        let element = self
            .elements
            .element(s.hit.triangle, side, s.hit.u, s.hit.v);
        mirrored_gloss(&s.params)
            && (values.is_some() || s.params.metallic >= 1.0)
            && self.tiles.of(element).is_none()
    }

    /// What the reflecting lobes (the BSDF's GGX lobe, with the metal's and the specular
    /// layer's Fresnel) of the mirrored-gloss surface `s`, seen along `dir`, reflect of
    /// the scene as the light field draws it (`total`: all of its light): the directions
    /// `rays` of the lobe's sequence of visible normals (rotated by the point's hash: the
    /// same for the same point and frames, [`ReflectionFrames`]), each weighted by the
    /// Fresnel at its microfacet and the masking on the way in (at grazing a rough lobe
    /// reflects less than a smooth surface's Fresnel says), the sky without the sun (its
    /// highlight is [`highlights`]' or the per-pixel pass's). Emitters seen directly are
    /// left out with `emitters_by_nee` (the per-pixel pass takes them at this surface with
    /// its full BSDF). Each direction's own mirrored-gloss surfaces are taken as mirrors.
    /// The lobe is `bsdf`'s and the scene's outside `environment`.
    fn blurred_reflection(
        &self,
        scene: &PlacedScene,
        objects: &ObjectLight,
        (s, dir): (&SurfaceHit, Vec3),
        total: &[[f32; 3]],
        emitters_by_nee: bool,
        (bsdf, environment, rays): (&Bsdf, &dyn Fn(Vec3) -> Vec3, Range<u64>),
    ) -> Vec3 {
        let lobe = bsdf.ggx();
        let frame = Frame::new(s.shading_normal);
        let wo = frame.to_local(-dir);
        if wo.z <= 0.0 {
            return Vec3::ZERO;
        }
        let seed = u64::from(s.hit.triangle) << 32
            ^ u64::from((s.hit.u * 65536.0) as u32) << 16
            ^ u64::from((s.hit.v * 65536.0) as u32);
        let mut sum = Vec3::ZERO;
        let count = rays.end - rays.start;
        for k in rays {
            let u = Vec2::new(r_sequence(R2, 2, 0, k, seed), r_sequence(R2, 2, 1, k, seed));
            let m = lobe.sample_visible(wo, u);
            let wi = fresnel::reflect(wo, m);
            if wi.z <= 0.0 {
                continue;
            }
            // A visible normal's sample: the Fresnel at its angle times the masking of
            // the way in given the way out (the rest of `f cos / pdf` cancels).
            let weight = bsdf.specular_reflectance(wo.dot(m)) * lobe.g2(wo, wi) / lobe.g1(wo);
            let ray = Ray::leaving(s.position, s.normal, frame.to_world(wi));
            let chain = follow(scene, ray, environment);
            // An emitter of the static scene seen directly is the per-pixel pass's
            // highlight where that pass runs at this surface; behind a mirror or glass, or
            // on a surface drawn as a mirror, what it shows comes only along this ray.
            let emission = match &chain.end {
                Some((e, r))
                    if chain.deltas == 0
                        && emitters_by_nee
                        && scene.object_of(e.hit.triangle).is_none() =>
                {
                    let mirror = self.drawn_as_mirror(e, r.dir, Some(total));
                    if mirror { Vec3::ZERO } else { e.emitted }
                }
                _ => Vec3::ZERO,
            };
            let chain = Chain {
                deltas: chain.deltas + 1,
                ..chain
            };
            // Beyond the first surface no lobe is sampled: any frame's directions do.
            let drawn = (Some(total), false, &ReflectionFrames::still(0));
            let (l, _) = self.lookup_chain(chain, objects, Some(scene), drawn);
            sum += weight * (shade_one(&l, total) - emission);
        }
        sum / count as f32
    }

    /// What the glossy surface `s` (its BSDF `own`), seen along `dir`, reflects of the room
    /// (as the light field draws it: `total`) beyond what its tile holds, where the tile
    /// widens the lobe to GGX `widened` because its bins resolve no narrower: the own
    /// lobe's blurred reflection less the widened lobe's, each from the directions `rays`
    /// of its sequence, drawn with the same numbers (so that where the room is smooth
    /// their noise cancels). A bright object small against a bin — the breakfast room's
    /// teapot in its marble table top — is spread by the tile over the bin; the lobe shows
    /// it. The sky is left out (the per-pixel pass sharpens its reflection:
    /// [`PixelDirect::with_sharp_sky_reflections`]), and so are the emitters seen directly
    /// (the per-pixel pass takes them with the surface's own BSDF).
    fn sharpened_reflection(
        &self,
        scene: &PlacedScene,
        objects: &ObjectLight,
        (s, dir): (&SurfaceHit, Vec3),
        total: &[[f32; 3]],
        (own, widened): (&Bsdf, f32),
        rays: Range<u64>,
    ) -> Vec3 {
        let outside = |_: Vec3| Vec3::ZERO;
        let lobe = |bsdf: &Bsdf| {
            let drawn = (bsdf, &outside as &dyn Fn(Vec3) -> Vec3, rays.clone());
            self.blurred_reflection(scene, objects, (s, dir), total, true, drawn)
        };
        lobe(own) - lobe(&own.widened(widened))
    }

    /// The lookup of what a chain of surfaces ends on; `placed` tells a moving object's
    /// surface apart (then it is lit from `objects`' probes, and the caches' samples do not
    /// count), and darkens the light field's part near the objects. `drawn`: the values
    /// the lookups are shaded with (where the CPU shades a part itself), whether the
    /// per-pixel pass adds the direct light at the point, and the frames whose directions
    /// the glossy lobes take.
    fn lookup_chain(
        &self,
        mut chain: Chain,
        objects: &ObjectLight,
        placed: Option<&PlacedScene>,
        drawn: LookupDrawn,
    ) -> (Lookup, Option<DirectPoint>) {
        let (values, direct_at_point, _) = drawn;
        let beside = self.beside_light(&chain.beside, placed);
        chain.emitted += beside;
        let Some((s, r)) = chain.end.take() else {
            let none = Lookup {
                emitted: chain.emitted.to_array(),
                ..Lookup::NONE
            };
            return (none, None);
        };
        // Moving objects' triangles have no elements: only the static scene's are looked up.
        let object = placed.and_then(|p| p.object_of(s.hit.triangle));
        let mut point = DirectPoint {
            surfaces: beside,
            ..s.direct_point(-r.dir, chain.weight)
        };
        if object.is_none()
            && self.drawn_as_mirror(&s, r.dir, values)
            && let Some(shown) =
                self.untiled_glossy(&chain, (&s, r.dir), &mut point, (objects, placed), drawn)
        {
            return shown;
        }
        if let Some(k) = object {
            return object_lookup(&chain, (&s, r.dir), point, (k, objects), direct_at_point);
        }
        let (open, near) = self.openness_at(&s, r.dir, objects);
        let samples = if near { 0.0 } else { 1.0 };
        // Where an object takes much of the hemisphere, the per-pixel pass gathers what
        // it changes of the point's indirect light ([`crate::object_gather`]) in place of
        // the sphere's darkening.
        let (open, samples) = if direct_at_point && 1.0 - open > GATHERED_OCCLUSION {
            point.albedo = albedo_towards(&s.params, s.shading_normal.dot(r.dir));
            point.gathered = true;
            (1.0, 0.0)
        } else {
            (open, samples)
        };
        let side = side_facing(s.normal, r.dir);
        let element = self
            .elements
            .element(s.hit.triangle, side, s.hit.u, s.hit.v);
        if let Some(g) = self.tiles.of(element) {
            let seen = (&s, r.dir);
            let l = self.tile_lookup(
                &chain,
                seen,
                g,
                &mut point,
                (open, samples),
                (objects, placed),
                drawn,
            );
            return (l, Some(point));
        }
        point.albedo = albedo_towards(&s.params, s.shading_normal.dot(r.dir));
        let cells = self.elements.triangles[s.hit.triangle as usize];
        let l = Lookup {
            base: cells.base(side),
            res: cells.res,
            u: s.hit.u,
            v: s.hit.v,
            weight: (chain.weight * open * point.albedo * std::f32::consts::FRAC_1_PI).to_array(),
            emitted: (chain.emitted + chain.weight * s.emitted).to_array(),
            samples,
            ..Lookup::NONE
        };
        (l, Some(point))
    }

    /// A glossy surface of the static scene without a tile, where the chain ends (`s` seen
    /// along `dir`, its point `point`): its Lambertian base's light, its highlights (the
    /// per-pixel pass's where it adds the direct light here, else the sun's and punctual
    /// lights' taken here), and what its lobe reflects: seen directly, blurred as the lobe
    /// blurs it; beyond a mirror or glass, the lookup along the mirrored ray (the sun's
    /// disc taken by the highlights, not along it). `None` where the mirrored ray leads
    /// nowhere: the surface is then looked up as any other.
    fn untiled_glossy(
        &self,
        chain: &Chain,
        (s, dir): (&SurfaceHit, Vec3),
        point: &mut DirectPoint,
        (objects, placed): (&ObjectLight, Option<&PlacedScene>),
        drawn: LookupDrawn,
    ) -> Option<(Lookup, Option<DirectPoint>)> {
        let (values, direct_at_point, frames) = drawn;
        let statics = self.scene.statics();
        let scene = placed.unwrap_or(&statics);
        let sky = |d: Vec3| sky(&self.lights, d);
        let bsdf = point.bsdf;
        let cos_o = s.shading_normal.dot(dir).abs();
        let base = values.map_or(Vec3::ZERO, |v| {
            let cells = self.elements.triangles[s.hit.triangle as usize];
            let side = side_facing(s.normal, dir);
            let irradiance = interpolate(v, cells.base(side), cells.res, s.hit.u, s.hit.v);
            bsdf.diffuse_reflectance(cos_o) * std::f32::consts::FRAC_1_PI * irradiance
        });
        if chain.deltas == 0
            && let Some(total) = self.light.get()
        {
            let blurred = self.blurred_reflection(
                scene,
                objects,
                (s, dir),
                total,
                direct_at_point,
                (&bsdf, &sky, frames.blurred_rays()),
            );
            let mut shown = base + blurred;
            if !direct_at_point {
                shown += highlights(scene, &self.lights, s, &bsdf, dir);
            }
            let l = Lookup {
                emitted: (chain.emitted + chain.weight * shown).to_array(),
                ..Lookup::NONE
            };
            point.reflected = Some(chain.weight * blurred);
            return Some((l, direct_at_point.then_some(*point)));
        }
        let shown = highlights(scene, &self.lights, s, &bsdf, dir) + base;
        let so_far = (
            chain.weight,
            chain.emitted + chain.weight * shown,
            chain.deltas,
        );
        let reflectance = bsdf.specular_reflectance(cos_o);
        let c = mirrored(scene, so_far, s, dir, reflectance, &sky)?;
        Some(self.lookup_chain(c, objects, placed, drawn))
    }

    /// The share of the hemisphere of `s` (seen along `dir`) the moving objects leave open,
    /// and whether they take so much that the caches' samples there are wrong
    /// ([`ObjectLight::openness`]); all open where there are none or no darkening.
    fn openness_at(&self, s: &SurfaceHit, dir: Vec3, objects: &ObjectLight) -> (f32, bool) {
        if objects.is_empty() || !self.darkening {
            return (1.0, false);
        }
        let n = s.normal * -s.normal.dot(dir).signum();
        let in_sight = |c: Vec3| {
            let to = c - s.position;
            let ray = Ray::leaving(s.position, s.normal, to.normalize());
            !self.scene.occluded(&ray, to.length())
        };
        objects.openness(s.position, n, &in_sight)
    }

    /// The lookup of glossy tile `g` where the chain ends (`s` seen along `dir`), its
    /// field's part scaled by `open` and worth `samples`. Seen directly by a pixel that
    /// takes its direct light here, a widened tile's surface also shows the room its own
    /// lobe reflects beyond the widened lobe ([`Self::sharpened_reflection`]), kept in
    /// `point`.
    #[allow(clippy::too_many_arguments)]
    fn tile_lookup(
        &self,
        chain: &Chain,
        (s, dir): (&SurfaceHit, Vec3),
        g: u32,
        point: &mut DirectPoint,
        (open, samples): (f32, f32),
        (objects, placed): (&ObjectLight, Option<&PlacedScene>),
        (values, direct_at_point, frames): LookupDrawn,
    ) -> Lookup {
        let (x, y) = self.tiles.view_coords(g, dir, s.shading_normal);
        let k = self.tiles.bins;
        let glossy = &self.tiles.tiles[g as usize];
        let tile = self.tiles.elements + g * k * k;
        let mut emitted = chain.emitted + chain.weight * s.emitted;
        if glossy.widened
            && direct_at_point
            && chain.deltas == 0
            && !frames.sharpened.is_empty()
            && let (Some(values), Some(total)) = (values, self.light.get())
        {
            let statics = self.scene.statics();
            let scene = placed.unwrap_or(&statics);
            let lobes = (&point.bsdf, glossy.bsdf.ggx().alpha);
            let reflected = self.sharpened_reflection(
                scene,
                objects,
                (s, dir),
                total,
                lobes,
                frames.sharpened_rays(),
            );
            // Never below what the tile shows: a difference of two few-ray estimates
            // can be.
            let shown = octahedral::interpolate(values, tile, k, x, y) * chain.weight * open;
            let sharpened = (chain.weight * reflected).max(-shown);
            emitted += sharpened;
            point.surfaces += sharpened;
            point.reflected = Some(sharpened);
        }
        Lookup {
            weight: (chain.weight * open).to_array(),
            emitted: emitted.to_array(),
            tile,
            bins: k,
            x,
            y,
            samples,
            ..Lookup::NONE
        }
    }

    /// Which pixels of `view` see a moving object through their centre.
    pub fn object_pixels(&self, view: &WallView) -> Vec<bool> {
        self.with_placed(|placed| {
            (0..view.size.width * view.size.height)
                .into_par_iter()
                .map(|i| {
                    let c = Vec2::new(
                        (i % view.size.width) as f32 + 0.5,
                        (i / view.size.width) as f32 + 0.5,
                    );
                    placed
                        .closest_hit(&view.ray(c), f32::INFINITY)
                        .is_some_and(|h| placed.object_of(h.triangle).is_some())
                })
                .collect()
        })
    }

    /// One lookup per pixel of `view`, through the pixel's centre, rows from the top. The
    /// first hits are found in packets of neighbouring pixels (coherent rays).
    pub fn pixels(&self, view: &WallView) -> Vec<Lookup> {
        self.pixels_and_points(view).0
    }

    /// As [`Visibility::pixels`], with each pixel's point for the per-pixel direct light;
    /// a view's first frame.
    pub fn pixels_and_points(&self, view: &WallView) -> (Vec<Lookup>, Vec<Option<DirectPoint>>) {
        let mut points = Vec::new();
        let lookups = self.pixels_into(view, None, &mut points, &ReflectionFrames::still(0));
        (lookups, points)
    }

    /// As [`Visibility::pixels_and_points`], the points written into `points` (a buffer
    /// kept from frame to frame: a wall's points are a hundred megabytes at projector
    /// sizes, and fresh memory costs the kernel's page clearing every frame). With `hits`,
    /// each pixel's first hit was found elsewhere (on the GPU): `hits.0[i]` is the closest
    /// hit of pixel `i`'s ray (rows from the top, through the pixel's centre, as
    /// [`WallView::ray`] makes it) in the static scene, and the rays that go on through
    /// mirrors and glass are traced there too, in batches, by `hits.1` ([`follow_all`]);
    /// the moving objects are tried here. The glossy lobes take the directions of `frames`.
    pub fn pixels_into(
        &self,
        view: &WallView,
        hits: Option<(&[Option<Hit>], &dyn StaticRays)>,
        points: &mut Vec<Option<DirectPoint>>,
        frames: &ReflectionFrames,
    ) -> Vec<Lookup> {
        match hits {
            Some((hits, further)) => {
                assert_eq!(hits.len(), view.size.area());
                let first_hits = |placed: &PlacedScene, rays: &[Ray], first: usize| {
                    let hits = &hits[first..first + rays.len()];
                    rays.iter()
                        .zip(hits)
                        .map(|(r, h)| placed.objects_closest_hit(r, f32::INFINITY, *h))
                        .collect()
                };
                self.pixels_with(view, points, &first_hits, Some(further), frames)
            }
            None => self.pixels_with(
                view,
                points,
                &|placed, rays, _| placed.closest_hits(rays, f32::INFINITY),
                None,
                frames,
            ),
        }
    }

    /// The pixels' lookups, their points written into `points`, with `first_hits(rays,
    /// i)` the closest hits of the rays of pixels `i` to `i + rays.len() − 1`; the rays
    /// past mirrors and glass traced by `further` in batches where given, else one by one
    /// here.
    fn pixels_with(
        &self,
        view: &WallView,
        points: &mut Vec<Option<DirectPoint>>,
        first_hits: &FirstHits,
        further: Option<&dyn StaticRays>,
        frames: &ReflectionFrames,
    ) -> Vec<Lookup> {
        let w = view.size.width as usize;
        let n = w * view.size.height as usize;
        let env = environment(&self.lights);
        let chunk = 8 * PACKET;
        let mut lookups = vec![Lookup::NONE; n];
        points.clear();
        points.resize(n, None);
        let objects = self.objects.read().unwrap_or_else(|e| e.into_inner());
        let placed = self.scene.placed(&objects.placements);
        self.with_drawn(|values, remainder| {
            let drawn = (values, remainder, frames);
            let draw = |chain| self.lookup_chain(chain, &objects, Some(&placed), drawn);
            // Each pixel whose chain ends at its first hit, or is followed here; the others
            // (index, ray, first hit) left to `further`.
            let beyond: Vec<(usize, Ray, Option<Hit>)> = lookups
                .par_chunks_mut(chunk)
                .zip(points.par_chunks_mut(chunk))
                .enumerate()
                .flat_map_iter(|(c, (lookups, points))| {
                    let rays: Vec<Ray> = (c * chunk..(c * chunk + lookups.len()))
                        .map(|i| view.ray(Vec2::new((i % w) as f32 + 0.5, (i / w) as f32 + 0.5)))
                        .collect();
                    let hits = first_hits(&placed, &rays, c * chunk);
                    let each = lookups.iter_mut().zip(points).zip(rays).zip(hits);
                    let mut beyond = Vec::new();
                    for (k, (((l, p), ray), hit)) in each.enumerate() {
                        let chain = match further {
                            None => Some(follow_from(&placed, ray, hit, &env)),
                            Some(_) => follow_first(&placed, ray, hit, &env),
                        };
                        match chain {
                            Some(chain) => {
                                let straight = chain.deltas == 0;
                                (*l, *p) = draw(chain);
                                spread_over_pixel(p, straight, view, 1, &placed);
                            }
                            None => beyond.push((c * chunk + k, ray, hit)),
                        }
                    }
                    beyond
                })
                .collect();
            if let Some(traced) = further.filter(|_| !beyond.is_empty()) {
                let (rays, firsts): (Vec<Ray>, Vec<Option<Hit>>) =
                    beyond.iter().map(|&(_, r, h)| (r, h)).unzip();
                let chains = follow_all(&placed, &rays, &firsts, &env, traced);
                let drawn: Vec<_> = chains.into_par_iter().map(draw).collect();
                for ((i, _, _), (l, p)) in beyond.into_iter().zip(drawn) {
                    (lookups[i], points[i]) = (l, p);
                }
            }
        });
        lookups
    }

    /// `view` drawn from the light field alone (its direct light included, nothing per
    /// pixel) with `k × k` lookups per pixel, a view's first frame: an antialiased image
    /// for comparison with a path-traced one. `values`: the elements' irradiance, then the
    /// tiles' radiance ([`crate::State::values`]). As the walls draw it, with the direct
    /// light per pixel: [`crate::WallPass::render`].
    pub fn render(&self, view: &WallView, values: &[[f32; 3]], k: u32) -> Image {
        let k = k.max(1);
        let first_frame = ReflectionFrames::still(0);
        self.render_cells(view, k, |placed, objects, ray| {
            let chain = follow(placed, ray, &environment(&self.lights));
            let drawn = (Some(values), false, &first_frame);
            let (l, _) = self.lookup_chain(chain, objects, Some(placed), drawn);
            shade_one(&l, values)
        })
    }

    /// Each pixel of `view` the mean of `radiance(placed, objects, ray)` over the rays of
    /// its `k × k` cells ([`grid_point`]).
    fn render_cells(
        &self,
        view: &WallView,
        k: u32,
        radiance: impl Fn(&PlacedScene, &ObjectLight, Ray) -> Vec3 + Sync,
    ) -> Image {
        let mut image = Image::new(view.size.width, view.size.height);
        let w = view.size.width as usize;
        let objects = self.objects.read().unwrap_or_else(|e| e.into_inner());
        let placed = self.scene.placed(&objects.placements);
        image.pixels.par_iter_mut().enumerate().for_each(|(i, px)| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            let sum: Vec3 = (0..k * k)
                .map(|s| {
                    radiance(
                        &placed,
                        &objects,
                        view.ray(Vec2::new(x, y) + grid_point(s, k)),
                    )
                })
                .sum();
            *px = sum / (k * k) as f32;
        });
        image
    }

    /// What cell `s` of pixel `i` of `view`, one of `k × k`, sees: its lookup and point
    /// (the point's estimates spread over the cell's patch where seen straight), the
    /// surfaces drawn as mirrors taking their base from `values`, the direct light at
    /// the point where `direct_at_point`, the glossy lobes the directions of `frames`
    /// ([`crate::WallPass::render`]).
    pub fn cell(
        &self,
        view: &WallView,
        (i, s, k): (usize, u32, u32),
        (values, direct_at_point, frames): (&[[f32; 3]], bool, &ReflectionFrames),
    ) -> (Lookup, Option<DirectPoint>) {
        let w = view.size.width as usize;
        let pixel = Vec2::new((i % w) as f32, (i / w) as f32);
        let ray = view.ray(pixel + grid_point(s, k));
        self.with_placed_objects(|placed, objects| {
            let chain = follow(placed, ray, &environment(&self.lights));
            let straight = chain.deltas == 0;
            let drawn = (Some(values), direct_at_point, frames);
            let (l, mut p) = self.lookup_chain(chain, objects, Some(placed), drawn);
            spread_over_pixel(&mut p, straight, view, k, placed);
            (l, p)
        })
    }

    /// Runs `f` with the scene as this frame places its moving objects, and their light.
    fn with_placed_objects<T>(&self, f: impl FnOnce(&PlacedScene, &ObjectLight) -> T) -> T {
        let objects = self.objects.read().unwrap_or_else(|e| e.into_inner());
        f(&self.scene.placed(&objects.placements), &objects)
    }
}

/// Spreads the estimates of the point `p` that one cell of a pixel (`k × k` of it) sees
/// over the cell's patch of its surface, where the eye sees it `straight` (through no
/// mirror or glass) and it is the static scene's.
fn spread_over_pixel(
    p: &mut Option<DirectPoint>,
    straight: bool,
    view: &WallView,
    k: u32,
    placed: &PlacedScene,
) {
    if let Some(p) = p
        .as_mut()
        .filter(|p| straight && placed.object_of(p.triangle).is_none())
    {
        p.span = pixel_span(view, k, p);
    }
}

/// The centre of cell `s` (row by row) of a `k × k` grid over a pixel, in the pixel's
/// own coordinates (`[0, 1]²`): where the `s`-th of a pixel's `k²` rays passes.
pub fn grid_point(s: u32, k: u32) -> Vec2 {
    (Vec2::new((s % k) as f32, (s / k) as f32) + 0.5) / k as f32
}

/// The light field's part of the sky's light ([`crate::State::sky_values`]) as a prior
/// for the mean of a pixel's own samples of it ([`PixelDirect::with_sky`]): it is worth
/// `samples` of them, `(k F + n S̄) / (k + n)`, so the first frame shows the field's smooth
/// sky and a still view converges to the exact one.
#[derive(Clone, Copy)]
pub struct SkyPrior<'a> {
    pub values: &'a [[f32; 3]],
    pub samples: f32,
}

/// How many of a pixel's own sky samples the light field's sky is worth on the walls
/// (`node --sky-per-pixel`): measured on the room's floor view (`docs/performance/history.md`,
/// "The sky per pixel"), 32 kept the first frame at the field's error and made every
/// later one better than 64 did; 16 and 4 were worse at the first frame.
pub const SKY_PRIOR_SAMPLES: f32 = 32.0;

impl SkyPrior<'_> {
    /// The direct light a pixel shows at lookup `l` from `e`, the mean of its `n`
    /// estimates: the sky's share blended with the field's sky; on a moving object, which
    /// has no field, its own samples alone.
    pub fn direct(&self, l: &Lookup, e: &Estimate, n: u32) -> Vec3 {
        if l.object != 0 {
            return e.radiance;
        }
        e.radiance - e.sky + self.blend(l, e.sky, n)
    }

    /// The sky's light at lookup `l` after `n` samples averaging `mean`.
    pub fn blend(&self, l: &Lookup, mean: Vec3, n: u32) -> Vec3 {
        let f = field_part(l, self.values);
        let n = n as f32;
        (self.samples * f + n * mean) / (self.samples + n).max(f32::MIN_POSITIVE)
    }
}

/// How [`Visibility`] is given the closest hits of a run of pixel rays (the scene as
/// placed this frame, the rays, and the first one's pixel index).
type FirstHits<'a> = dyn Fn(&PlacedScene, &[Ray], usize) -> Vec<Option<Hit>> + Sync + 'a;

/// What a lookup is drawn with: the values it is shaded with where the CPU shades a part
/// itself, whether the per-pixel pass adds the direct light at its point, and the frames
/// whose directions the glossy lobes take.
/// The lookup of a moving object's point where the chain ends (`s` seen along `dir`, its
/// point `point`, object `k`): where the per-pixel pass takes the point's light, it gathers
/// the object's indirect light there ([`crate::object_gather`]); else its probe gives it.
fn object_lookup(
    chain: &Chain,
    (s, dir): (&SurfaceHit, Vec3),
    mut point: DirectPoint,
    (k, objects): (usize, &ObjectLight),
    direct_at_point: bool,
) -> (Lookup, Option<DirectPoint>) {
    point.albedo = albedo_towards(&s.params, s.shading_normal.dot(dir));
    point.gathered = direct_at_point;
    let indirect = if direct_at_point {
        Vec3::ZERO
    } else {
        point.albedo * std::f32::consts::FRAC_1_PI * objects.irradiance(k, s.shading_normal)
    };
    let l = Lookup {
        emitted: (chain.emitted + chain.weight * (s.emitted + indirect)).to_array(),
        object: k as u32 + 1,
        ..Lookup::NONE
    };
    (l, Some(point))
}

type LookupDrawn<'a> = (Option<&'a [[f32; 3]]>, bool, &'a ReflectionFrames);

/// The light field's part of lookup `l` (its emitted light left out), from `values`.
fn field_part(l: &Lookup, values: &[[f32; 3]]) -> Vec3 {
    let field = Lookup {
        emitted: [0.0; 3],
        ..*l
    };
    shade_one(&field, values)
}

/// The radiance of one lookup; `values`: the elements' irradiance, then the tiles'
/// radiance.
pub fn shade_one(l: &Lookup, values: &[[f32; 3]]) -> Vec3 {
    let mut c = Vec3::from(l.emitted);
    if l.base != u32::MAX {
        c += Vec3::from(l.weight) * interpolate(values, l.base, l.res, l.u, l.v);
    }
    if l.tile != u32::MAX {
        c += Vec3::from(l.weight) * octahedral::interpolate(values, l.tile, l.bins, l.x, l.y);
    }
    c
}

/// The radiance of every lookup (the CPU twin of the render node's shader).
pub fn shade(lookups: &[Lookup], values: &[[f32; 3]]) -> Vec<Vec3> {
    lookups.iter().map(|l| shade_one(l, values)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use holocave_cave::Size;
    use holocave_scene::LoadOptions;

    /// The packets give every pixel the lookup of its own centre's ray, at a size that is
    /// not a multiple of a packet (a partial packet ends each task): the same element or
    /// tile, and every number equal within the rounding that tells the two triangle tests
    /// apart (the single ray's fuses multiply-adds, the packet's does not). Each number is
    /// a few sums of products of terms up to about 1 in size (barycentrics, Fresnel
    /// weights, emission), so the two differ by a few units of f32 rounding of 1: the
    /// bound is 16 of them, relative where a number exceeds 1 (measured: 1.5).
    #[test]
    fn pixels_are_the_lookups_of_their_centres() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell.gltf");
        let scene = Arc::new(Scene::load(&path, &LoadOptions::default()).unwrap());
        let vis = Visibility::of(scene.clone(), &crate::Settings::default());
        let (w, h) = (37, 23);
        let view = WallView::through_camera(&scene.cameras[0], Size::new(w, h));
        let lookups = vis.pixels(&view);
        assert_eq!(lookups.len(), (w * h) as usize);
        for (i, l) in lookups.iter().enumerate() {
            let (x, y) = ((i as u32 % w) as f32 + 0.5, (i as u32 / w) as f32 + 0.5);
            let one = vis.lookup(view.ray(Vec2::new(x, y)));
            let close = |a: f32, b: f32| (a - b).abs() <= 16.0 * f32::EPSILON * a.abs().max(1.0);
            let floats = |l: &Lookup| {
                let ([a, b, c], [d, e, f]) = (l.weight, l.emitted);
                [l.u, l.v, l.x, l.y, a, b, c, d, e, f]
            };
            assert!(
                (l.base, l.res, l.tile, l.bins) == (one.base, one.res, one.tile, one.bins)
                    && floats(l)
                        .into_iter()
                        .zip(floats(&one))
                        .all(|(a, b)| close(a, b)),
                "pixel ({x}, {y}): {l:?}, its own ray {one:?}"
            );
        }
    }
}
