//! A bake: the visibility pass (every subfield's lines), direct light, then bounces until
//! the light not yet propagated is below the tolerance. After every bounce the caller
//! gets the state to save, so a killed bake resumes from its last completed bounce (the
//! visibility pass and direct light are deterministic and are simply done again).

use std::time::{Duration, Instant};

use glam::Vec3;
use holocave_scene::Scene;
use holocave_tracer::frame::Frame;
use holocave_tracer::lights::Lights;
use rayon::prelude::*;

use crate::direct::direct_irradiance;
use crate::directions::Directions;
use crate::elements::{Elements, cell_index};
use crate::exitance::Exitance;
use crate::pools::Pools;
use crate::propagate::{Lines, Received, Sending, bounce, flux};
use crate::reflection::Reflection;
use crate::subfield::{Grid, Sphere, Subfield, cast};
use crate::surface::{diffuse_albedo, seen_at};
use crate::tiles::Tiles;

/// What a bake is asked for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Directions over the sphere (rounded up to a geodesic sphere: 12, 42, 92, 162,
    /// 252, 362, 492, 642, …); the subfields are half as many.
    pub directions: usize,
    /// Lines across each subfield (`N`; the grid is `N × N`).
    pub resolution: u32,
    /// Element size in scene units; `None`: twice the lines' spacing (`4R / N`), so
    /// that about four lines of each direction land on an element facing it.
    pub element_size: Option<f32>,
    /// Next-event samples per element for the direct light.
    pub direct_samples: u32,
    /// Stop when the light not yet propagated is below this fraction of the
    /// inter-reflected light propagated so far (see [`tail`]).
    pub tolerance: f64,
    pub max_bounces: u32,
    /// Surfaces with a GGX lobe whose `α` (roughness²) is below this are glossy and get
    /// directional radiance tiles (`tiles`); rougher ones are diffuse elements. 0: none.
    /// The default, 0.5 (roughness 0.71), gives tiles to every lobe that differs clearly
    /// from a diffuse one: at `α = 0.5` a metal's reflected radiance still varies by more
    /// than a factor 3 between normal and grazing views.
    pub glossy_alpha: f32,
    /// Bins along each side of a tile (`k`: `k × k` over the hemisphere, each about
    /// `√(2π)/k` radians across: 18° for 8).
    pub tile_bins: u32,
}

impl Settings {
    /// The number of directions a bake uses for `directions` asked (the geodesic sphere
    /// [`Directions::at_least`] gives).
    pub fn rounded_directions(directions: usize) -> usize {
        let mut f = 1usize;
        while 10 * f * f + 2 < directions {
            f += 1;
        }
        10 * f * f + 2
    }
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            directions: 642,
            resolution: 256,
            element_size: None,
            direct_samples: 64,
            tolerance: 1e-3,
            max_bounces: 200,
            glossy_alpha: 0.5,
            tile_bins: 8,
        }
    }
}

/// Where a bake stands after a bounce: everything needed to draw it, or to go on.
#[derive(Clone, Debug, PartialEq)]
pub struct State {
    /// Bounces propagated so far (0: direct light only).
    pub bounces: u32,
    /// Irradiance of every element: all bounces so far.
    pub irradiance: Vec<[f32; 3]>,
    /// Radiance the last bounce sends out (what the next bounce propagates); for an
    /// element with a tile, the radiosity its tile's last bounce amounts to
    /// ([`Tiles::radiosity`]).
    pub last: Vec<[f32; 3]>,
    /// The glossy tiles' radiance (`tiles × k²` bins, tile after tile): all bounces so
    /// far. Empty when the scene has no glossy surfaces.
    pub tiles: Vec<[f32; 3]>,
    /// The tiles' radiance of the last bounce (what the next bounce propagates).
    pub tiles_last: Vec<[f32; 3]>,
    /// The part of `irradiance` that came by next-event estimation from emissive
    /// triangles, punctual lights and the sun (`direct`): what a view that computes the
    /// direct light per pixel ([`crate::pixel_direct`]) leaves out of the light field.
    pub direct: Vec<[f32; 3]>,
    /// The same part of `tiles`.
    pub tiles_direct: Vec<[f32; 3]>,
    /// The part of `irradiance` that came from the sky along the lines at the first
    /// bounce (smoothed as `irradiance` is, once converged): what a view that also takes
    /// the sky per pixel ([`crate::PixelDirect::with_sky`]) leaves out. Empty when the
    /// file was baked without it (version 3).
    pub sky: Vec<[f32; 3]>,
    /// The same part of `tiles`.
    pub tiles_sky: Vec<[f32; 3]>,
    /// The part of `irradiance` that emitters sent through mirrors and glass at the first
    /// bounce, their caustics (kept sharp, as the direct part): what a view that takes
    /// caustics per pixel ([`crate::caustics`]) leaves out. Empty in a scene without
    /// mirrors or glass.
    pub caustics: Vec<[f32; 3]>,
    /// The flux (luminance) that first reached the surfaces: direct light, the sky along
    /// the lines, what delta surfaces show.
    pub arrived: f64,
    /// The flux each bounce sent out, relative to `arrived`; the last is the residual.
    pub residuals: Vec<f64>,
    pub converged: bool,
}

impl State {
    /// What the lookups read ([`crate::view::shade_one`], the render node's shader): the
    /// elements' irradiance, then the tiles' radiance.
    pub fn values(&self) -> Vec<[f32; 3]> {
        [self.irradiance.as_slice(), self.tiles.as_slice()].concat()
    }

    /// What the lookups read when the direct light is computed per pixel: [`State::values`]
    /// less the next-event part ([`State::direct`], [`State::tiles_direct`]), which the
    /// bake keeps exactly as computed (the smoothing leaves it alone), so the difference
    /// is the sky along the lines, caustics and the inter-reflected light. Negative
    /// values can only be the rounding of that subtraction, and are made zero.
    pub fn indirect_values(&self) -> Vec<[f32; 3]> {
        [
            less(&self.irradiance, &self.direct),
            less(&self.tiles, &self.tiles_direct),
        ]
        .concat()
    }

    /// What the lookups read when the sky's light is computed per pixel as well:
    /// [`State::indirect_values`] less the sky's first arrival ([`State::sky_values`]):
    /// caustics and the inter-reflected light. `None` for a state that does not hold the
    /// sky's part.
    pub fn indirect_values_without_sky(&self) -> Option<Vec<[f32; 3]>> {
        Some(less(&self.indirect_values(), &self.sky_values()?))
    }

    /// `values` as the lookups read them (the elements', then the tiles') less the
    /// elements' caustic part ([`State::caustics`]), for a view that takes the caustics per
    /// pixel; as they are where the state holds none.
    pub fn less_caustics(&self, values: Vec<[f32; 3]>) -> Vec<[f32; 3]> {
        let n = self.caustics.len();
        if n != self.irradiance.len() || values.len() < n {
            return values;
        }
        [less(&values[..n], &self.caustics), values[n..].to_vec()].concat()
    }

    /// The sky's first arrival as the lookups read it: the elements' part, then the
    /// tiles'; `None` for a file that does not hold it.
    pub fn sky_values(&self) -> Option<Vec<[f32; 3]>> {
        (self.sky.len() == self.irradiance.len() && self.tiles_sky.len() == self.tiles.len())
            .then(|| [self.sky.as_slice(), self.tiles_sky.as_slice()].concat())
    }

    /// The light the last bounce sent out, relative to the light that first arrived.
    pub fn residual(&self) -> f64 {
        self.residuals.last().copied().unwrap_or(1.0)
    }

    /// The estimated light still to propagate (see [`tail`]).
    pub fn tail(&self) -> f64 {
        tail(&self.residuals)
    }
}

/// What a bake reports as it goes.
#[derive(Clone, Copy, Debug)]
pub enum Stage {
    Visibility { done: usize, total: usize },
    Direct { done: usize, total: usize },
    Bounce { bounce: u32, residual: f64 },
}

/// The cost of a bake.
#[derive(Clone, Debug, Default)]
pub struct Stats {
    pub directions: usize,
    pub subfields: usize,
    pub lines_cast: u64,
    pub lines_stored: u64,
    pub crossings: u64,
    pub links: u64,
    pub elements: usize,
    /// Glossy element sides with a directional radiance tile.
    pub tiles: usize,
    /// Bytes the tiles take in the file and on the GPU (`tiles × k² × 12`).
    pub tile_memory: u64,
    /// Bytes held while propagating (lines, links, element arrays, tiles).
    pub memory: u64,
    pub visibility: Duration,
    pub direct: Duration,
    pub propagation: Duration,
}

/// The light not yet propagated after the last bounce, as a fraction of the
/// inter-reflected light propagated so far (bounces 1…k): the bounces fall off
/// geometrically by `q = r_k / r_{k−1}`, so what is left is `r_k q / (1 − q)`. Measured
/// against inter-reflected light rather than all light that arrived, so that sunlit
/// outer walls that reflect into the void do not make an interior's tail look small.
/// Infinite until two bounces are known.
pub fn tail(residuals: &[f64]) -> f64 {
    let k = residuals.len();
    if k < 3 {
        return f64::INFINITY;
    }
    let (r, prev) = (residuals[k - 1], residuals[k - 2]);
    if r <= 0.0 {
        return 0.0;
    }
    let q = r / prev;
    if q >= 1.0 {
        return f64::INFINITY;
    }
    let propagated: f64 = residuals[1..].iter().sum();
    r * q / (1.0 - q) / propagated
}

/// Calls `f(e, neighbourhood)` for every element `e` with the 3 × 3 cells around it on
/// its triangle side (itself included) and their tent weights: 4 at the centre, 2 at
/// the sides, 1 at the corners.
fn neighbourhoods(elements: &Elements, mut f: impl FnMut(usize, &[(usize, f32)])) {
    let mut around = Vec::with_capacity(9);
    for cells in &elements.triangles {
        let r = cells.res as i64;
        for side in 0..2 {
            let base = cells.base(side);
            for j in 0..r {
                for i in 0..r - j {
                    around.clear();
                    for dj in -1..=1i64 {
                        for di in -1..=1i64 {
                            let (ii, jj) = (i + di, j + dj);
                            if ii < 0 || jj < 0 || ii + jj > r - 1 {
                                continue;
                            }
                            let e = (base + cell_index(ii as u32, jj as u32, r as u32)) as usize;
                            let tent = f32::from(2u8 >> di.unsigned_abs())
                                * f32::from(2u8 >> dj.unsigned_abs());
                            around.push((e, tent));
                        }
                    }
                    f(
                        (base + cell_index(i as u32, j as u32, r as u32)) as usize,
                        &around,
                    );
                }
            }
        }
    }
}

/// The least open share whose lines' light is put over the open part alone: a sliver
/// less open than this is hit by few lines, and is drawn from its neighbours (the
/// smoothing weighs it by its open area).
const LEAST_OPEN: f32 = 1.0 / 16.0;

/// Each value (an element's irradiance, or a tile's bin) over its element's open part
/// (`open`: the element's open share, per value): the lines brought what they brought
/// over the whole element, none of it to its part inside an object resting on it, so
/// the light beyond the `sharp` part (taken at open points already) is divided by the
/// open share. The propagation itself keeps the whole areas: given a covered element's
/// open area, a sliver returned light to the object's inside with a gain above one, and
/// the bounces diverged.
fn over_open_part(open: &[f32], sharp: &[[f32; 3]], total: &[[f32; 3]]) -> Vec<[f32; 3]> {
    (total.iter().zip(sharp).zip(open))
        .map(|((t, s), &o)| {
            if o >= 1.0 || o <= 0.0 {
                return *t;
            }
            let (t, s) = (Vec3::from(*t), Vec3::from(*s));
            (s + (t - s) / o.max(LEAST_OPEN)).to_array()
        })
        .collect()
}

/// The drawn irradiance: the light that must stay sharp (`sharp`: direct light with its
/// shadows, caustics) as it is; the rest (the sky along the lines and the inter-reflected
/// light), smooth in nature but carrying the lines' sampling noise, averaged over each
/// element's 3 × 3 neighbourhood of cells on its triangle side (a tent, weighted by area).
pub fn smooth_indirect(
    elements: &Elements,
    area: &[f32],
    sharp: &[[f32; 3]],
    total: &[[f32; 3]],
) -> Vec<[f32; 3]> {
    let indirect: Vec<Vec3> = total
        .iter()
        .zip(sharp)
        .map(|(t, d)| Vec3::from(*t) - Vec3::from(*d))
        .collect();
    let mut out = total.to_vec();
    neighbourhoods(elements, |e, around| {
        let (mut sum, mut w) = (Vec3::ZERO, 0.0);
        for &(n, tent) in around {
            sum += indirect[n] * area[n] * tent;
            w += area[n] * tent;
        }
        if w > 0.0 {
            out[e] = (Vec3::from(sharp[e]) + sum / w).to_array();
        }
    });
    out
}

/// The drawn glossy tiles: their sharp light (`sharp`: next-event samples with the exact
/// BSDF, caustics) as it is; the rest, which came along the lines, averaged bin by bin
/// over the tiles of each element's 3 × 3 neighbourhood (as [`smooth_indirect`]). A tile's
/// bins see only the few line directions inside its lobe, and which lines of a direction
/// hit a small element varies from element to element: unsmoothed, a glossy table top
/// showed that as grain at the elements' scale.
pub fn smooth_tiles(
    elements: &Elements,
    tiles: &Tiles,
    area: &[f32],
    sharp: &[[f32; 3]],
    total: &[[f32; 3]],
) -> Vec<[f32; 3]> {
    let k = tiles.per_tile();
    let mut out = total.to_vec();
    if tiles.is_empty() {
        return out;
    }
    let mut sum = vec![Vec3::ZERO; k];
    neighbourhoods(elements, |e, around| {
        let Some(g) = tiles.of(e as u32) else { return };
        sum.iter_mut().for_each(|s| *s = Vec3::ZERO);
        let mut w = 0.0;
        for &(n, tent) in around {
            let Some(h) = tiles.of(n as u32) else {
                continue;
            };
            let at = h as usize * k;
            for (b, s) in sum.iter_mut().enumerate() {
                *s += (Vec3::from(total[at + b]) - Vec3::from(sharp[at + b])) * area[n] * tent;
            }
            w += area[n] * tent;
        }
        if w > 0.0 {
            let at = g as usize * k;
            for (b, s) in sum.iter().enumerate() {
                out[at + b] = (Vec3::from(sharp[at + b]) + *s / w).to_array();
            }
        }
    });
    out
}

/// The element layout of a bake of `scene` with `settings`.
pub fn layout(scene: &Scene, settings: &Settings) -> Elements {
    Elements::new(scene, element_size(scene, settings))
}

/// The glossy tiles of a bake of `scene` with `settings`, on its element layout.
pub fn tiles(scene: &Scene, settings: &Settings, elements: &Elements) -> Tiles {
    Tiles::new(scene, elements, settings)
}

/// `a − b`, value by value, never negative (what is left can only be rounding below zero).
fn less(a: &[[f32; 3]], b: &[[f32; 3]]) -> Vec<[f32; 3]> {
    a.iter()
        .zip(b)
        .map(|(a, b)| (Vec3::from(*a) - Vec3::from(*b)).max(Vec3::ZERO).to_array())
        .collect()
}

/// The least area a line's light is spread over (see the bake): a quarter of the
/// smallest cross-section a line of any direction stands for. The same from the scene and
/// the settings alone, so that the tiles' layout can leave out glossy elements smaller
/// than it ([`Tiles::new`]).
pub fn least_area(scene: &Scene, settings: &Settings) -> f32 {
    let directions = Directions::at_least(settings.directions);
    let sphere = Sphere::of(scene);
    (0..directions.lines.len())
        .map(|k| {
            let omega = directions.solid_angle[directions.pair[k][0] as usize];
            Grid::new(
                directions.lines[k],
                k as u32,
                sphere,
                settings.resolution.max(1),
                omega,
            )
            .cross_section()
        })
        .fold(f32::INFINITY, f32::min)
        * 0.25
}

/// The element size of a bake: the settings', or twice the lines' spacing.
pub fn element_size(scene: &Scene, settings: &Settings) -> f32 {
    let sphere = Sphere::of(scene);
    settings
        .element_size
        .unwrap_or(4.0 * sphere.radius / settings.resolution.max(1) as f32)
}

/// The sky and sun as seen looking along `dir`.
pub fn environment(lights: &Lights) -> impl Fn(Vec3) -> Vec3 + Sync + '_ {
    move |dir: Vec3| {
        let sky = sky(lights, dir);
        let sun = lights.sun_along(dir).map_or(Vec3::ZERO, |(l, _)| l);
        sky + sun
    }
}

/// The sky alone looking along `dir`: what a line brings in from outside the scene (the
/// sun's disk, far smaller than the direction spacing, comes by next-event estimation;
/// a line that happened to point into it would carry it over a whole direction's
/// solid angle).
pub(crate) fn sky(lights: &Lights, dir: Vec3) -> Vec3 {
    lights.sky.as_ref().map_or(Vec3::ZERO, |s| s.radiance(dir))
}

/// The sky's mean over the cone of solid angle `omega` about `dir`: what the lines of a
/// direction that stands for `omega` of the sphere bring in from outside. Taken at `dir`
/// alone, a direction whose cone straddles the horizon brought the bright sky just above
/// it over the whole cone, half of which is the darker ground: low sky through a window
/// (the breakfast room's, facing a low sun) lit the wall across from it a tenth too
/// bright. Equal parts of the cone's solid angle, rings in `1 − cos θ` by spokes.
pub(crate) fn sky_over(lights: &Lights, dir: Vec3, omega: f32) -> Vec3 {
    const RINGS: usize = 8;
    const SPOKES: usize = 16;
    if lights.sky.is_none() {
        return Vec3::ZERO;
    }
    let frame = Frame::new(dir);
    let one_minus_cos = (omega / std::f32::consts::TAU).clamp(0.0, 2.0);
    let mut sum = Vec3::ZERO;
    for ring in 0..RINGS {
        let x = (ring as f32 + 0.5) / RINGS as f32 * one_minus_cos;
        let sin = (x * (2.0 - x)).max(0.0).sqrt();
        for spoke in 0..SPOKES {
            // Each ring's spokes turned by half a step from the last's.
            let turn = (spoke as f32 + 0.5 * (ring % 2) as f32) / SPOKES as f32;
            let phi = std::f32::consts::TAU * turn;
            let local = Vec3::new(sin * phi.cos(), sin * phi.sin(), 1.0 - x);
            sum += sky(lights, frame.to_world(local).normalize());
        }
    }
    sum / (RINGS * SPOKES) as f32
}

/// Casts the subfields of one bake: the same on every thread and in every worker
/// process, so a subfield is the same whoever casts it.
pub struct Caster<'a> {
    scene: &'a Scene,
    settings: Settings,
    pub directions: Directions,
    sphere: Sphere,
    pub elements: Elements,
    lights: Lights,
}

impl<'a> Caster<'a> {
    pub fn new(scene: &'a Scene, settings: &Settings) -> Caster<'a> {
        Caster {
            scene,
            settings: *settings,
            directions: Directions::at_least(settings.directions),
            sphere: Sphere::of(scene),
            elements: layout(scene, settings),
            lights: Lights::new(scene),
        }
    }

    /// How many subfields there are.
    pub fn count(&self) -> usize {
        self.directions.lines.len()
    }

    /// The grid of subfield `k`.
    pub fn grid(&self, k: usize) -> Grid {
        let d = self.directions.lines[k];
        let omega = self.directions.solid_angle[self.directions.pair[k][0] as usize];
        Grid::new(
            d,
            k as u32,
            self.sphere,
            self.settings.resolution.max(1),
            omega,
        )
    }

    /// Subfield `k`: its lines and their crossings.
    pub fn cast(&self, k: usize) -> Subfield {
        cast(
            self.scene,
            &self.elements,
            &self.grid(k),
            &environment(&self.lights),
        )
    }
}

/// Who casts the subfields: this process's threads, and workers in other processes.
pub trait Casting: Sync {
    /// Every subfield of `caster`, in order, reporting each one done through `done`.
    fn cast_all(&self, caster: &Caster, done: &(dyn Fn() + Sync)) -> Vec<Subfield>;
}

/// This process's threads (rayon's pool) only.
pub struct Threads;

impl Casting for Threads {
    fn cast_all(&self, caster: &Caster, done: &(dyn Fn() + Sync)) -> Vec<Subfield> {
        (0..caster.count())
            .into_par_iter()
            .map(|k| {
                let s = caster.cast(k);
                done();
                s
            })
            .collect()
    }
}

/// Bakes `scene` on this process's threads, from `resume` if given. `save` is called
/// after each bounce.
pub fn bake<E>(
    scene: &Scene,
    settings: &Settings,
    resume: Option<State>,
    progress: &(dyn Fn(Stage) + Sync),
    save: &mut dyn FnMut(&State) -> Result<(), E>,
) -> Result<(State, Stats), E> {
    bake_with(scene, settings, resume, &Threads, progress, save)
}

/// Bakes `scene` with the subfields cast by `casting`, from `resume` if given. `save` is
/// called after each bounce. The result does not depend on who cast what.
///
/// The stages: the lines of every subfield ([`cast_lines`]); the elements that receive
/// light ([`Receivers`]); the direct light ([`direct_light`]); the light that arrives
/// first, along the lines ([`first_arrival`]); the state to go on from (a resumed one, or
/// the first bounce's, [`FirstArrival::state`]); the bounces until the light left is below
/// the tolerance ([`propagate`]).
pub fn bake_with<E>(
    scene: &Scene,
    settings: &Settings,
    resume: Option<State>,
    casting: &dyn Casting,
    progress: &(dyn Fn(Stage) + Sync),
    save: &mut dyn FnMut(&State) -> Result<(), E>,
) -> Result<(State, Stats), E> {
    let lights = Lights::new(scene);
    let caster = Caster::new(scene, settings);
    let elements = &caster.elements;
    let mut stats = Stats {
        directions: caster.directions.len(),
        subfields: caster.count(),
        elements: elements.count,
        ..Stats::default()
    };
    let cast = cast_lines(&caster, &lights, casting, progress, &mut stats);
    let receivers = Receivers::new(scene, settings, elements, &mut stats);
    // How each diffuse element takes and sends light over directions.
    let exitance = Exitance::new(
        scene,
        &receivers.centre,
        &receivers.tiles,
        &receivers.needed,
    );
    let (direct, open, direct_tiles) = direct_light(
        (scene, settings, &lights),
        elements,
        (&receivers, &exitance),
        progress,
        &mut stats,
    );
    // The light that arrives first: direct light, the sky along the lines, what delta
    // surfaces show (caustics). Computed again on resume (deterministic).
    let start = Instant::now();
    let tiles = &receivers.tiles;
    let reflection = Reflection::new(tiles);
    let pools = Pools::new(
        scene,
        elements,
        tiles,
        &receivers.area,
        &receivers.needed,
        receivers.least,
    );
    let drawing = Drawing::new(elements, &receivers, &pools, &open);
    let lines = Lines {
        pools: Some(&pools),
        subfields: &cast.subfields,
        dirs: &caster.directions.lines,
        weight: &cast.weight,
        ends: &cast.ends,
        area: &receivers.receiving,
        tiles,
        exitance: &exitance,
        reflection: &reflection,
    };
    let first = first_arrival(&lines, elements.count);
    stats.propagation += start.elapsed();
    let mut state = match resume {
        Some(s) => first.resumed(s, direct, direct_tiles),
        None => {
            let s = first.state(direct, direct_tiles, &receivers);
            save(&s)?;
            s
        }
    };
    let start = Instant::now();
    propagate(
        &mut state, &lines, &receivers, &drawing, &first, settings, progress, save,
    )?;
    stats.propagation += start.elapsed();
    Ok((state, stats))
}

/// What the visibility pass gives the bounces: every subfield's lines, each subfield's
/// weight (its direction's solid angle times a line's cross-section) and the sky at both
/// ends of its lines.
struct Cast {
    subfields: Vec<Subfield>,
    weight: Vec<f32>,
    ends: Vec<(Vec3, Vec3)>,
}

/// The visibility pass: every line of every subfield, cast by `casting`, with the counts
/// and the time in `stats`.
fn cast_lines(
    caster: &Caster,
    lights: &Lights,
    casting: &dyn Casting,
    progress: &(dyn Fn(Stage) + Sync),
    stats: &mut Stats,
) -> Cast {
    let start = Instant::now();
    let total = caster.count();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let subfields = casting.cast_all(caster, &|| {
        let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        progress(Stage::Visibility { done: n, total });
    });
    stats.visibility = start.elapsed();
    let directions = &caster.directions;
    let weight: Vec<f32> = (0..caster.count())
        .map(|k| caster.grid(k).cross_section())
        .zip(&directions.pair)
        .map(|(c, [a, _])| directions.solid_angle[*a as usize] * c)
        .collect();
    let ends: Vec<(Vec3, Vec3)> = directions
        .lines
        .iter()
        .zip(&directions.pair)
        .map(|(d, [a, _])| {
            let omega = directions.solid_angle[*a as usize];
            (sky_over(lights, -*d, omega), sky_over(lights, *d, omega))
        })
        .collect();
    for s in &subfields {
        stats.lines_cast += u64::from(s.lines_cast);
        stats.lines_stored += s.line_start.len() as u64 - 1;
        stats.crossings += s.crossings.len() as u64;
        stats.links += s.links.len() as u64;
    }
    Cast {
        subfields,
        weight,
        ends,
    }
}

/// The elements as receivers of light: their areas and centres, the glossy tiles, their
/// albedo and which of them need light at all, and the area a line's light is spread over.
struct Receivers {
    area: Vec<f32>,
    centre: Vec<(u32, f32, f32)>,
    tiles: Tiles,
    albedo: Vec<Vec3>,
    needed: Vec<bool>,
    /// The least area a line's light is spread over ([`least_area`]).
    least: f32,
    /// An element's area, but never less than `least`. An element much smaller than a
    /// line (a chain link, a leaf) is hit by a line in few directions, each bringing
    /// `h²/A` times its radiance; two such elements facing each other along one line pass
    /// light back and forth with a gain of `(ρ Δω h² / π A)²` per round trip, above 1 for
    /// small enough `A`, and the series diverges (Sponza did). Clamped, such elements get
    /// less light than they should (the render cache's samples correct them), and the
    /// series converges.
    receiving: Vec<f32>,
}

impl Receivers {
    /// The receivers of `elements`, with the tiles' counts and the bake's memory in
    /// `stats` (whose line and link counts are known).
    fn new(scene: &Scene, settings: &Settings, elements: &Elements, stats: &mut Stats) -> Self {
        let (area, centre) = elements.areas_and_centres(scene);
        let tiles = Tiles::new(scene, elements, settings);
        let albedo: Vec<Vec3> = centre
            .par_iter()
            .enumerate()
            .map(|(e, &(t, u, v))| {
                let s = seen_at(scene, t, u, v);
                if s.delta {
                    Vec3::ZERO
                } else if tiles.of(e as u32).is_some() {
                    // Reflects through its tile; marked as needing light.
                    Vec3::ONE
                } else {
                    diffuse_albedo(&s.params)
                }
            })
            .collect();
        let needed: Vec<bool> = albedo.iter().map(|a| a.max_element() > 0.0).collect();
        let least = least_area(scene, settings);
        let receiving: Vec<f32> = area.iter().map(|a| a.max(least)).collect();
        stats.tiles = tiles.tiles.len();
        stats.tile_memory = tiles.len() as u64 * 12;
        stats.memory = stats.crossings * 8
            + stats.links * 40
            + (stats.lines_stored + stats.subfields as u64) * 4
            + elements.count as u64 * (4 + 12 * 4)
            + if tiles.is_empty() {
                0
            } else {
                elements.count as u64 * 4 + stats.tiles as u64 * 120 + stats.tile_memory * 4
            };
        Receivers {
            area,
            centre,
            tiles,
            albedo,
            needed,
            least,
            receiving,
        }
    }

    /// What a bounce's irradiance `e` (and its tiles' `bins`) sends out: `ρ/π E` from
    /// diffuse elements, and from an element with a tile the radiosity of its tile's bins
    /// (only for the stopping rule: lines read the tile itself).
    fn reflect(&self, e: &[[f32; 3]], bins: &[[f32; 3]]) -> Vec<[f32; 3]> {
        let mut out: Vec<[f32; 3]> = e
            .iter()
            .zip(&self.albedo)
            .map(|(e, a)| (Vec3::from(*e) * *a * std::f32::consts::FRAC_1_PI).to_array())
            .collect();
        let k = self.tiles.per_tile();
        for (g, t) in self.tiles.tiles.iter().enumerate() {
            out[t.element as usize] = self.tiles.radiosity(&bins[g * k..(g + 1) * k]).to_array();
        }
        out
    }
}

/// The direct light on every element that needs light, and on the tiles, with each
/// element's open share (the part not inside a closed object resting on it); its time
/// in `stats`.
fn direct_light(
    (scene, settings, lights): (&Scene, &Settings, &Lights),
    elements: &Elements,
    (receivers, exitance): (&Receivers, &Exitance),
    progress: &(dyn Fn(Stage) + Sync),
    stats: &mut Stats,
) -> (Vec<[f32; 3]>, Vec<f32>, Vec<[f32; 3]>) {
    let start = Instant::now();
    let tris = elements.triangles.len();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let direct = direct_irradiance(
        scene,
        lights,
        elements,
        &receivers.needed,
        settings.direct_samples,
        (&receivers.tiles, exitance),
        &|| {
            let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            if n.is_multiple_of(64) || n == tris {
                progress(Stage::Direct {
                    done: n,
                    total: tris,
                });
            }
        },
    );
    stats.direct = start.elapsed();
    direct
}

/// A converged part of the light as it is drawn: over the elements' open parts (their part
/// inside a closed object resting on them left out, [`over_open_part`]), all but its sharp
/// part smoothed (elements, pools, tiles).
struct Drawing<'a> {
    elements: &'a Elements,
    tiles: &'a Tiles,
    pools: &'a Pools,
    /// Each element's open area: the smoothing weighs it by that.
    open_area: Vec<f32>,
    /// The open share an element's value is divided by: its own, or its pool's (a pool
    /// receives the light of its members over their summed area).
    value_open: Vec<f32>,
    /// Each tile bin's element's open share.
    tile_open: Vec<f32>,
}

impl<'a> Drawing<'a> {
    fn new(
        elements: &'a Elements,
        receivers: &'a Receivers,
        pools: &'a Pools,
        open: &[f32],
    ) -> Self {
        let tiles = &receivers.tiles;
        let open_area: Vec<f32> = receivers
            .area
            .iter()
            .zip(open)
            .map(|(a, o)| a * o)
            .collect();
        let tile_open: Vec<f32> = (tiles.tiles.iter())
            .flat_map(|t| std::iter::repeat_n(open[t.element as usize], tiles.per_tile()))
            .collect();
        let pool_open: Vec<f32> = (pools.members.iter().zip(&pools.area))
            .map(|(m, a)| m.iter().map(|&e| open_area[e as usize]).sum::<f32>() / a)
            .collect();
        let value_open: Vec<f32> = (open.iter().zip(&pools.of))
            .map(|(&o, &p)| {
                if p == u32::MAX {
                    o
                } else {
                    pool_open[p as usize]
                }
            })
            .collect();
        Drawing {
            elements,
            tiles,
            pools,
            open_area,
            value_open,
            tile_open,
        }
    }

    /// The elements' light `total` as drawn, `sharp` of it kept sharp.
    fn elements(&self, sharp: &[[f32; 3]], total: &[[f32; 3]]) -> Vec<[f32; 3]> {
        let open_part = over_open_part(&self.value_open, sharp, total);
        let smoothed = smooth_indirect(self.elements, &self.open_area, sharp, &open_part);
        self.pools.smooth(&self.open_area, sharp, &smoothed)
    }

    /// The tiles' light `total` as drawn, `sharp` of it kept sharp.
    fn tiles(&self, sharp: &[[f32; 3]], total: &[[f32; 3]]) -> Vec<[f32; 3]> {
        let open_part = over_open_part(&self.tile_open, sharp, total);
        smooth_tiles(
            self.elements,
            self.tiles,
            &self.open_area,
            sharp,
            &open_part,
        )
    }
}

/// The light that arrives first along the lines (from nothing sent: the sky at the lines'
/// ends and what delta surfaces show of the emitters), split into its caustics and the
/// sky's first arrival.
struct FirstArrival {
    got: Received,
    /// What delta surfaces show of the emitters: the first bounce without the sky at the
    /// lines' ends (`None`: no mirror or glass).
    caustics: Option<Received>,
    /// The first bounce less its caustics: as noisy as the inter-reflected light (which
    /// lines of a direction hit a small element varies from element to element), so it
    /// is smoothed with it.
    sky: Vec<[f32; 3]>,
    sky_tiles: Vec<[f32; 3]>,
}

/// The first arrival along `lines` onto `count` elements.
fn first_arrival(lines: &Lines, count: usize) -> FirstArrival {
    let zero = vec![[0f32; 3]; count];
    let zero_tiles = vec![[0f32; 3]; lines.tiles.len()];
    let nothing_sent = || Sending {
        radiance: &zero,
        tiles: &zero_tiles,
        first_bounce: true,
    };
    let got = bounce(lines, nothing_sent());
    let caustics = lines
        .subfields
        .iter()
        .any(|s| !s.links.is_empty())
        .then(|| {
            let no_ends = vec![(Vec3::ZERO, Vec3::ZERO); lines.ends.len()];
            let lines = Lines {
                ends: &no_ends,
                ..*lines
            };
            bounce(&lines, nothing_sent())
        });
    let (sky, sky_tiles) = match &caustics {
        Some(c) => (
            less(&got.irradiance, &c.irradiance),
            less(&got.tiles, &c.tiles),
        ),
        None => (got.irradiance.clone(), got.tiles.clone()),
    };
    FirstArrival {
        got,
        caustics,
        sky,
        sky_tiles,
    }
}

impl FirstArrival {
    /// The caustics' irradiance as a state keeps it (empty: none).
    fn caustics_kept(&self) -> Vec<[f32; 3]> {
        (self.caustics.as_ref()).map_or_else(Vec::new, |c| c.irradiance.clone())
    }

    /// A resumed state `s` with the light computed again (deterministic: the same as the
    /// saved one): the direct light, the caustics, and the sky part where the file has
    /// none (raw until converged, smoothed with the irradiance after).
    fn resumed(&self, mut s: State, direct: Vec<[f32; 3]>, direct_tiles: Vec<[f32; 3]>) -> State {
        s.direct = direct;
        s.tiles_direct = direct_tiles;
        if s.sky_values().is_none() {
            s.sky = self.sky.clone();
            s.tiles_sky = self.sky_tiles.clone();
        }
        s.caustics = self.caustics_kept();
        s
    }

    /// The state after the first arrival: the direct light and the first bounce, with
    /// what the first bounce sends out and its residual.
    fn state(&self, direct: Vec<[f32; 3]>, direct_tiles: Vec<[f32; 3]>, r: &Receivers) -> State {
        let first = add(&direct, &self.got.irradiance);
        let first_tiles = add(&direct_tiles, &self.got.tiles);
        let arrived = flux(&first, &r.area) / std::f64::consts::PI;
        let last = r.reflect(&first, &first_tiles);
        let residual = flux(&last, &r.area) / arrived.max(f64::MIN_POSITIVE);
        State {
            bounces: 0,
            irradiance: first,
            last,
            tiles: first_tiles.clone(),
            tiles_last: first_tiles,
            direct,
            tiles_direct: direct_tiles,
            sky: self.sky.clone(),
            tiles_sky: self.sky_tiles.clone(),
            caustics: self.caustics_kept(),
            arrived,
            residuals: vec![residual],
            converged: false,
        }
    }
}

/// `a + b`, element by element.
fn add(a: &[[f32; 3]], b: &[[f32; 3]]) -> Vec<[f32; 3]> {
    a.iter()
        .zip(b)
        .map(|(a, b)| (Vec3::from(*a) + Vec3::from(*b)).to_array())
        .collect()
}

/// Bounces `state` along `lines` until the light left is below the tolerance (or the
/// bounces reach their limit, or a bounce sends out more than the one before: the
/// estimate has come apart), saving it after each; the converged light is then drawn
/// ([`Drawing`]), all but the sharp part (the direct light and the caustics) smoothed.
#[allow(clippy::too_many_arguments)]
fn propagate<E>(
    state: &mut State,
    lines: &Lines,
    receivers: &Receivers,
    drawing: &Drawing,
    first: &FirstArrival,
    settings: &Settings,
    progress: &(dyn Fn(Stage) + Sync),
    save: &mut dyn FnMut(&State) -> Result<(), E>,
) -> Result<(), E> {
    let caustics = (first.caustics.as_ref()).map(|c| {
        (
            add(&state.direct, &c.irradiance),
            add(&state.tiles_direct, &c.tiles),
        )
    });
    // Without mirrors or glass, the direct light itself (not a copy: the tiles' can be a
    // gigabyte).
    let (sharp, sharp_tiles): (&[[f32; 3]], &[[f32; 3]]) = match &caustics {
        Some((e, t)) => (e, t),
        None => (&state.direct, &state.tiles_direct),
    };
    while !state.converged {
        if tail(&state.residuals) < settings.tolerance || state.bounces >= settings.max_bounces {
            state.converged = true;
            state.irradiance = drawing.elements(sharp, &state.irradiance);
            state.tiles = drawing.tiles(sharp_tiles, &state.tiles);
            // The sky's part drawn as the irradiance is (linear, so the split still sums
            // to the total).
            state.sky = drawing.elements(&vec![[0f32; 3]; first.sky.len()], &first.sky);
            state.tiles_sky =
                drawing.tiles(&vec![[0f32; 3]; first.sky_tiles.len()], &first.sky_tiles);
            return save(state);
        }
        let got = bounce(
            lines,
            Sending {
                radiance: &state.last,
                tiles: &state.tiles_last,
                first_bounce: false,
            },
        );
        state.irradiance = add(&state.irradiance, &got.irradiance);
        state.tiles = add(&state.tiles, &got.tiles);
        state.last = receivers.reflect(&got.irradiance, &got.tiles);
        state.tiles_last = got.tiles;
        state.bounces += 1;
        let r = flux(&state.last, &receivers.area) / state.arrived.max(f64::MIN_POSITIVE);
        state.residuals.push(r);
        // With albedos at most 1 a bounce cannot send out more light than the bounce
        // before it: if one does, the estimate has come apart (say so, keep what there is).
        if !r.is_finite()
            || (state.residuals.len() > 2 && r > state.residuals[state.residuals.len() - 2] * 1.5)
        {
            tracing::error!(
                "bounce {}: the light sent out grew ({:?}); propagation stopped",
                state.bounces,
                &state.residuals[state.residuals.len().saturating_sub(3)..]
            );
            state.converged = true;
            return save(state);
        }
        progress(Stage::Bounce {
            bounce: state.bounces,
            residual: r,
        });
        save(state)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use holocave_scene::{Daylight, SceneParts, Sky, SkyModel};

    /// The breakfast room's clear sky (its sun low over +X) over a ground of a fifth of
    /// its zenith: each direction's light over its share of the sphere sums to the sky's
    /// whole, within the cones' misfit to the directions' cells.
    #[test]
    fn the_directions_bring_in_the_skys_light_over_their_cells() {
        let sun = Vec3::new(0.92, 0.30, -0.25).normalize();
        let parts = SceneParts {
            positions: vec![[Vec3::ZERO, Vec3::X, Vec3::Z]],
            shading: vec![holocave_scene::TriangleShading {
                normals: None,
                uvs: [glam::Vec2::ZERO; 3],
                material: 0,
            }],
            materials: vec![holocave_scene::Material::default()],
            daylight: Daylight {
                sky: Some(Sky {
                    model: SkyModel::CieClear {
                        zenith: Vec3::ONE,
                        sun,
                    },
                    ground: Vec3::splat(0.2),
                }),
                ..Default::default()
            },
            ..SceneParts::default()
        };
        let scene = Scene::from_parts(parts, std::path::Path::new("sky")).unwrap();
        let lights = Lights::new(&scene);
        let directions = Directions::at_least(642);
        let (mut point, mut cone) = (0f64, 0f64);
        for (d, [a, _]) in directions.lines.iter().zip(&directions.pair) {
            let omega = directions.solid_angle[*a as usize];
            for d in [*d, -*d] {
                point += f64::from(sky(&lights, d).x * omega);
                cone += f64::from(sky_over(&lights, d, omega).x * omega);
            }
        }
        // The whole, over a fine grid in (cos θ, φ) (equal solid angles).
        let n = 2000;
        let mut whole = 0f64;
        for i in 0..n {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            for j in 0..n {
                let phi = std::f32::consts::TAU * (j as f32 + 0.5) / n as f32;
                let s = (1.0 - z * z).max(0.0).sqrt();
                let d = Vec3::new(s * phi.cos(), z, s * phi.sin());
                whole += f64::from(sky(&lights, d).x);
            }
        }
        whole *= 4.0 * std::f64::consts::PI / (n * n) as f64;
        eprintln!(
            "the sky's whole {whole}: directions at their centres {point}, over cones {cone}"
        );
        assert!((cone / whole - 1.0).abs() < 0.005, "{cone} against {whole}");
    }
}
