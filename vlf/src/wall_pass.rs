//! The per-pixel wall pass: the radiance a wall draws for a ray, in named stages, with one
//! owner. Every consumer draws through [`WallPass`]: the render node's walls
//! (`render_node::VlfBase`, which runs the stages over a frame's pixels at once and keeps
//! their running means), `holocave vlf view` ([`WallPass::render`]), `compare`'s measure of
//! the field ([`WallPass::radiance`]), glare's fisheye and the gathers' bounces
//! ([`crate::gather`], through [`extras`]).
//!
//! The stages, in order:
//!
//! | stage | where |
//! |---|---|
//! | 1. first hit, and the chain through mirrors and glass | [`crate::surface`] (`follow`) |
//! | 2. the surface a pixel sees, 3. the light field's lookup, with sharpened and blurred glossy reflections | [`Visibility`] ([`Lookup`], [`DirectPoint`]) |
//! | 4. the direct light: light choice, BSDF, MIS, shadow rays; a moving object's own indirect light, gathered | [`PixelDirect`] ([`WallPass::direct_mean`]), [`crate::object_gather`] |
//! | 5. the running means across frames | the wall's [`crate::Accumulator`], a moving eye's pixels carried to its next view ([`crate::carry`], [`WallPass::surfaces_carried`]); one ray: the mean of [`FrameContext::estimates`] |
//! | 6. caustics, tile albedo, the sky prior | [`WallPass::added`] |
//! | 7. edges | [`crate::glow_edges`], [`crate::surface_edges`] (a wall's batch, where a pixel's neighbours are known) |
//! | 8. the lookup shaded, under the render cache | [`shade_one`] (the render node's `cache/shade_field.wgsl` on the GPU) |
//!
//! A frame's parameters reach the stages by value, as one [`FrameContext`]; nothing is set
//! beforehand for the next frame to find.

use std::sync::Arc;

use glam::Vec3;
use holocave_cave::WallView;
use holocave_scene::{Hit, Ray, Scene};
use holocave_tracer::film::Image;
use rayon::prelude::*;

use crate::bake::{Settings, State};
use crate::baked::{Blended, Opened};
use crate::footprint::Screen;
use crate::object_gather::ObjectGather;
use crate::pixel_direct::{DirectPoint, Estimate, PixelDirect};
use crate::split::Split;
use crate::static_rays::StaticRays;
use crate::view::{
    AVERAGED_FRAMES, Lookup, ReflectionFrames, SKY_PRIOR_SAMPLES, SkyPrior, Visibility, shade,
    shade_one,
};
use crate::{glow_edges, surface_edges};

/// A baked light field as the walls draw it: the scene's visibility, the direct light per
/// pixel and the field's values it leaves ([`Split`]).
pub struct WallPass {
    visibility: Visibility,
    /// The next-event part: the walls' direct light per pixel, and the gathers'.
    direct: PixelDirect,
    /// The elements' irradiance, then the tiles' radiance: all of it, and without what
    /// is taken per pixel (what the lookups read when the direct light is per pixel).
    total: Arc<Vec<[f32; 3]>>,
    remainder: Arc<Vec<[f32; 3]>>,
    /// With the sky per pixel, the field's sky: a prior for it, worth `sky_samples` of
    /// a pixel's own.
    sky: Option<Vec<[f32; 3]>>,
    sky_samples: f32,
    /// Whether the direct light is computed per pixel (never for a scene without a light
    /// next-event estimation takes).
    per_pixel: bool,
}

/// What a frame's pixels see before their light per pixel (stages 1–3): their lookups,
/// and the pixels at the outlines of what glows ([`glow_edges`]). A still view's are the
/// same frame after frame, but where the glossy lobes take new directions.
#[derive(Clone)]
pub struct FrameSurfaces {
    pub lookups: Vec<Lookup>,
    pub edges: glow_edges::GlowEdges,
}

/// One frame's parameters, for every stage.
#[derive(Clone, Copy, Debug)]
pub struct FrameContext<'a> {
    /// What the lookups read: [`WallPass::values`], or those with gathers kept in them.
    pub values: &'a [[f32; 3]],
    /// The frames whose directions of each glossy lobe the lookups take.
    pub reflections: &'a ReflectionFrames,
    /// The direct-light estimates a ray's mean holds: what a still wall's pixel holds
    /// after its frames ([`WallPass::estimates_after`]).
    pub estimates: u32,
}

impl WallPass {
    /// The pass over `visibility` (a bake's layout for its scene) of the field `state`
    /// baked with `settings`, the whole sky per pixel with `sky_per_pixel` (an error for
    /// a state without a sky part), the direct light per pixel where the scene has any.
    pub fn new(
        visibility: Visibility,
        settings: &Settings,
        state: &State,
        sky_per_pixel: bool,
    ) -> Result<WallPass, String> {
        Self::of_parts(visibility, settings, (state, None), sky_per_pixel)
    }

    /// [`Self::new`] of a state that may be a bake set's blend of two bakes (`blended`),
    /// whose remainders are smoothed each alone ([`Split::of_parts`]).
    fn of_parts(
        visibility: Visibility,
        settings: &Settings,
        (state, blended): (&State, Option<&Blended>),
        sky_per_pixel: bool,
    ) -> Result<WallPass, String> {
        let scene = visibility.scene().clone();
        let layout = (visibility.elements(), visibility.tiles());
        let Split {
            direct,
            remainder,
            sky,
            caustics,
        } = Split::of_parts(scene, settings, (state, blended), layout, sky_per_pixel)?;
        let total = Arc::new(state.values());
        visibility.light_objects(total.clone());
        if let Some(c) = caustics {
            visibility.draw_caustics(c);
        }
        let pass = WallPass {
            visibility,
            direct,
            total,
            remainder: Arc::new(remainder),
            sky,
            sky_samples: SKY_PRIOR_SAMPLES,
            per_pixel: false,
        };
        Ok(pass.with_direct(true))
    }

    /// [`Self::new`] for a light field opened for `scene`.
    pub fn of_opened(
        scene: Arc<Scene>,
        opened: Opened,
        sky_per_pixel: bool,
    ) -> Result<WallPass, String> {
        let Opened {
            file,
            elements,
            tiles,
            blended,
        } = opened;
        let visibility = Visibility::new(scene, elements, tiles);
        let parts = blended.as_deref();
        Self::of_parts(
            visibility,
            &file.settings,
            (&file.state, parts),
            sky_per_pixel,
        )
    }

    /// With `on` false, without the moving objects' darkening of the light field near
    /// them (to measure its effect; the walls always darken).
    pub fn with_darkening(mut self, on: bool) -> Self {
        if !on {
            self.visibility = self.visibility.without_darkening();
        }
        self
    }

    /// With `on` false, the light field alone as baked (its direct light included, no
    /// shadow rays); with `on` true (as made), the direct light per pixel and the field's
    /// remainder, where the scene has a light that pass takes.
    pub fn with_direct(mut self, on: bool) -> Self {
        self.per_pixel = on && !self.direct.is_empty();
        let values = if self.per_pixel {
            &self.remainder
        } else {
            &self.total
        };
        self.visibility.draw_with(values.clone(), self.per_pixel);
        self
    }

    /// With the sky per pixel, the field's sky worth `samples` of a pixel's own samples
    /// of it ([`SKY_PRIOR_SAMPLES`] unless told).
    pub fn with_sky_prior(mut self, samples: f32) -> Self {
        self.sky_samples = samples;
        self
    }

    /// Whether the direct light is computed per pixel.
    pub fn direct_per_pixel(&self) -> bool {
        self.per_pixel
    }

    /// The scene drawn.
    pub fn scene(&self) -> &Arc<Scene> {
        self.visibility.scene()
    }

    /// Stages 1–3: the scene's visibility.
    pub fn visibility(&self) -> &Visibility {
        &self.visibility
    }

    /// Stage 4: the direct light per pixel.
    pub fn direct(&self) -> &PixelDirect {
        &self.direct
    }

    /// What the lookups read: the field's remainder beside the direct light per pixel,
    /// else all of it.
    pub fn values(&self) -> &[[f32; 3]] {
        if self.per_pixel {
            &self.remainder
        } else {
            &self.total
        }
    }

    /// All of the field's light.
    pub fn total(&self) -> &Arc<Vec<[f32; 3]>> {
        &self.total
    }

    /// The field less what is taken per pixel.
    pub fn remainder(&self) -> &Arc<Vec<[f32; 3]>> {
        &self.remainder
    }

    /// With the whole sky per pixel, the field's sky as the prior of a pixel's mean.
    pub fn sky_prior(&self) -> Option<SkyPrior<'_>> {
        self.sky.as_deref().map(|values| SkyPrior {
            values,
            samples: self.sky_samples,
        })
    }

    /// The estimates a still wall's pixel holds after `frames` frames at one point: its
    /// first frame's, then one a frame.
    pub fn estimates_after(&self, frames: u32) -> u32 {
        self.direct.first_estimates() + frames.max(1) - 1
    }

    /// Stage 4's gathers on the moving objects ([`crate::object_gather`]), from all of
    /// the field's light.
    pub fn object_gather(&self) -> ObjectGather<'_> {
        ObjectGather {
            visibility: &self.visibility,
            direct: &self.direct,
            values: &self.total,
        }
    }

    /// Stage 4 for one point: the mean of `estimates` estimates at `p` of its direct
    /// light and, on a moving object, its gathered indirect light, of sample sequence
    /// `seed`, with the moving objects where they stand.
    pub fn direct_mean(&self, p: &DirectPoint, seed: u64, estimates: u32) -> Estimate {
        let gather = self.object_gather();
        (self.visibility).with_placed(|placed| {
            let mut e = self.direct.mean(placed, p, seed, 0, estimates);
            let gathered: Vec3 = (0..u64::from(estimates.max(1)))
                .map(|n| gather.estimate(placed, p, seed, n))
                .sum();
            e.radiance += gathered / estimates.max(1) as f32;
            e
        })
    }

    /// Stage 6: what the per-pixel pass adds to lookup `l` (read from `values`) beyond
    /// what the lookup itself shows: the direct light `e`, the mean of `n` estimates, over
    /// the field's sky where the sky is per pixel; the tile's albedo put right at the
    /// pixel's angle; and `caustic`, the caustics at its point ([`Self::caustics`]). Never
    /// so negative that the pixel is: a mean of few gathers of what an object takes away
    /// from the field's light ([`crate::object_gather`]) can take away more than it shows.
    pub fn added(
        &self,
        values: &[[f32; 3]],
        l: &Lookup,
        (e, n): (&Estimate, u32),
        caustic: Vec3,
    ) -> Vec3 {
        let direct = match self.sky_prior() {
            Some(prior) => prior.direct(l, e, n),
            None => e.radiance,
        };
        let added = direct + self.direct.tile_albedo(l, values) + caustic;
        added.max(-shade_one(l, values))
    }

    /// Stage 6's caustics at `p`, the point of lookup `l`, over the footprint of a pixel
    /// of `screen` where given (a wall's pixel), else at the point.
    pub fn caustics(&self, l: &Lookup, p: &DirectPoint, screen: Option<&Screen>) -> Vec3 {
        self.visibility.caustic_light(l, p, screen)
    }

    /// Stages 4–8 for one lookup `l` whose point is `p`: its radiance in frame `ctx`, the
    /// direct light the mean of `ctx.estimates` estimates of sequence `seed`, the
    /// caustics over a pixel of `screen` where given.
    pub fn radiance_of(
        &self,
        ctx: FrameContext,
        (l, p): (&Lookup, Option<&DirectPoint>),
        seed: u64,
        screen: Option<&Screen>,
    ) -> Vec3 {
        let shown = shade_one(l, ctx.values);
        if !self.per_pixel {
            return shown;
        }
        let (e, n, caustic) = match p {
            Some(p) => (
                self.direct_mean(p, seed, ctx.estimates),
                ctx.estimates.max(1),
                self.caustics(l, p, screen),
            ),
            None => (Estimate::default(), 0, Vec3::ZERO),
        };
        shown + self.added(ctx.values, l, (&e, n), caustic)
    }

    /// The radiance a wall draws along `ray` in frame `ctx` (no pixel: the direct light
    /// and caustics at the point itself), its direct light of sample sequence `seed`.
    /// What glare's fisheye and `compare` draw.
    pub fn radiance(&self, ctx: FrameContext, ray: Ray, seed: u64) -> Vec3 {
        let hit = self.scene().closest_hit(&ray, f32::INFINITY);
        let (l, p, _) = (self.visibility).lookup_point_and_hit(ray, hit, ctx.reflections);
        self.radiance_of(ctx, (&l, p.as_ref()), seed, None)
    }

    /// The per-pixel stages of one frame of `view`, over all its pixels at once:
    /// [`Self::surfaces`], then [`Self::light`]. The lookups, for stage 8; the pixels'
    /// points in `points`.
    pub fn frame(
        &self,
        view: &WallView,
        hits: Option<(&[Option<Hit>], &dyn StaticRays)>,
        points: &mut Vec<Option<DirectPoint>>,
        reflections: &ReflectionFrames,
        direct: impl FnOnce(&mut [Lookup], &[Option<DirectPoint>]),
    ) -> Vec<Lookup> {
        let surfaces = self.surfaces(view, hits, points, reflections);
        self.light(view, surfaces, points, direct)
    }

    /// Stages 1–3 of a frame of `view`: what its pixels see, before the light per pixel
    /// (the first hits found here in packets, or with `hits` found elsewhere, each pixel's
    /// closest static hit and the walk that traces the rays past mirrors and glass), the
    /// glossy lobes taking the directions of `reflections`; the pixels' points written
    /// into `points`.
    pub fn surfaces(
        &self,
        view: &WallView,
        hits: Option<(&[Option<Hit>], &dyn StaticRays)>,
        points: &mut Vec<Option<DirectPoint>>,
        reflections: &ReflectionFrames,
    ) -> FrameSurfaces {
        let lookups = self.visibility.pixels_into(view, hits, points, reflections);
        let edges = glow_edges::find(view, &lookups, points);
        FrameSurfaces { lookups, edges }
    }

    /// Stages 1–3 of a frame of `view` whose pixels show what they carried from the last
    /// frame (`lookups`, at `points`: [`crate::carry`]) but for those marked in `anew`,
    /// drawn here each along its centre's ray, the glossy lobes taking the directions of
    /// `reflections`; then the frame's glow edges.
    pub fn surfaces_carried(
        &self,
        view: &WallView,
        (mut lookups, points): (Vec<Lookup>, &mut [Option<DirectPoint>]),
        anew: &[bool],
        reflections: &ReflectionFrames,
    ) -> FrameSurfaces {
        self.draw_cells(view, (&mut lookups, points), reflections, |i, _| anew[i]);
        let edges = glow_edges::find(view, &lookups, points);
        FrameSurfaces { lookups, edges }
    }

    /// Stages 1–3 again, for the pixels of a still view's kept surfaces (`lookups`, at
    /// `points`) whose lookups take their glossy lobes' reflections anew each frame
    /// ([`DirectPoint::reflected`]), each along its centre's ray, the lobes taking the
    /// directions of `reflections`; the others drawn as they were. Past
    /// [`AVERAGED_FRAMES`] a still view's reflections are averaged over enough directions:
    /// each such pixel's reflection is taken out of its lookup instead, and it shows the
    /// mean its wall keeps.
    pub fn redraw_reflections(
        &self,
        view: &WallView,
        lookups: &mut [Lookup],
        points: &mut [Option<DirectPoint>],
        reflections: &ReflectionFrames,
    ) {
        let averaged = reflections.sharpened.is_empty()
            && reflections.blurred.start > u64::from(AVERAGED_FRAMES);
        if !averaged {
            let reflected = |_, p: &Option<DirectPoint>| p.is_some_and(|p| p.reflected.is_some());
            self.draw_cells(view, (lookups, points), reflections, reflected);
            return;
        }
        (lookups.par_iter_mut().zip(points.par_iter_mut())).for_each(|(l, p)| {
            if let Some(r) = p.as_mut().and_then(|p| p.reflected.take()) {
                l.emitted = (Vec3::from(l.emitted) - r).to_array();
            }
        });
    }

    /// Stages 1–3 for the pixels of `view` that `which(i, point)` picks, each along its
    /// centre's ray, the glossy lobes taking the directions of `reflections`: their
    /// lookups and points written over `lookups` and `points`.
    fn draw_cells(
        &self,
        view: &WallView,
        (lookups, points): (&mut [Lookup], &mut [Option<DirectPoint>]),
        reflections: &ReflectionFrames,
        which: impl Fn(usize, &Option<DirectPoint>) -> bool + Sync,
    ) {
        let vis = &self.visibility;
        vis.with_drawn(|drawn, direct_at_point| {
            let drawn = (drawn.unwrap_or(self.values()), direct_at_point, reflections);
            (lookups
                .par_iter_mut()
                .zip(points.par_iter_mut())
                .enumerate())
            .filter(|(i, (_, p))| which(*i, p))
            .for_each(|(i, (l, p))| (*l, *p) = vis.cell(view, (i, 0, 1), drawn));
        });
    }

    /// Stages 4–7 of a frame of `view` whose pixels see `surfaces` at `points`: `direct`
    /// where the direct light is per pixel (it adds each pixel's direct light, running
    /// mean and extras to its lookup's `emitted` light), then the edges. The lookups, for
    /// stage 8.
    pub fn light(
        &self,
        view: &WallView,
        surfaces: FrameSurfaces,
        points: &[Option<DirectPoint>],
        direct: impl FnOnce(&mut [Lookup], &[Option<DirectPoint>]),
    ) -> Vec<Lookup> {
        let FrameSurfaces { mut lookups, edges } = surfaces;
        if self.per_pixel {
            direct(&mut lookups, points);
        }
        let vis = &self.visibility;
        surface_edges::resolve(vis, view, &mut lookups, points, &edges.pixels());
        edges.resolve(vis, view, &mut lookups);
        lookups
    }

    /// Stages 4–6 of a still view's frame with `estimates` estimates a pixel, without a
    /// history: each pixel's mean of them at its point (pixel `i` takes sample sequence
    /// `i`, as a wall's), with the caustics over its footprint, added to its lookup.
    fn add_still(
        &self,
        view: &WallView,
        values: &[[f32; 3]],
        (lookups, points): (&mut [Lookup], &[Option<DirectPoint>]),
        estimates: u32,
    ) {
        let screen = Screen::of(view, 1);
        let each = lookups.par_iter_mut().zip(points).enumerate();
        each.for_each(|(i, (l, p))| {
            let (e, n, caustic) = match p {
                Some(p) => (
                    self.direct_mean(p, i as u64, estimates),
                    estimates.max(1),
                    self.caustics(l, p, Some(&screen)),
                ),
                None => (Estimate::default(), 0, Vec3::ZERO),
            };
            let added = self.added(values, l, (&e, n), caustic);
            l.emitted = (Vec3::from(l.emitted) + added).to_array();
        });
    }

    /// `view` drawn as a still wall draws it after `frames` frames (an image to compare
    /// with a path-traced one), the lookups reading `values` ([`Self::values`], or with
    /// gathers kept in them). With `k` = 1 a wall's frame itself, through [`Self::frame`]
    /// (on the CPU: what a wall with `--rays cpu` shows of the field on its first frame,
    /// bit for bit); with `k` > 1 each pixel the mean of `k × k` rays over it, cell `s` of
    /// pixel `i` taking sample sequence `i k² + s`, without the edges' stage (the rays
    /// resolve them).
    pub fn render(&self, view: &WallView, values: &[[f32; 3]], k: u32, frames: u32) -> Image {
        let k = k.max(1);
        let reflections = ReflectionFrames::after(frames);
        let estimates = self.estimates_after(frames);
        if k == 1 {
            let mut points = Vec::new();
            let lookups = self.frame(view, None, &mut points, &reflections, |l, p| {
                self.add_still(view, values, (l, p), estimates)
            });
            let mut image = Image::new(view.size.width, view.size.height);
            image.pixels = shade(&lookups, values);
            return image;
        }
        let ctx = FrameContext {
            values,
            reflections: &reflections,
            estimates,
        };
        let screen = Screen::of(view, k);
        let mut image = Image::new(view.size.width, view.size.height);
        image.pixels.par_iter_mut().enumerate().for_each(|(i, px)| {
            let sum: Vec3 = (0..k * k)
                .map(|s| {
                    let drawn = (values, self.per_pixel, &reflections);
                    let (l, p) = self.visibility.cell(view, (i, s, k), drawn);
                    let seed = i as u64 * u64::from(k * k) + u64::from(s);
                    self.radiance_of(ctx, (&l, p.as_ref()), seed, Some(&screen))
                })
                .sum();
            *px = sum / (k * k) as f32;
        });
        image
    }
}
