//! Caustics per pixel: the light the emitters, the sun and the punctual lights send onto a
//! surface through mirrors and glass, from a photon map (Jensen's caustic map).
//!
//! The field holds the emitters' part per element ([`crate::State::caustics`]), which
//! spreads a glass sphere's focused caustic over the elements around it: on the Cornell
//! box the spot under the sphere read 0.03 where the path tracer has 0.16. The sun's and
//! the punctual lights' part was on no wall at all: their shadow rays stop at mirrors and
//! glass, and the field's lines carry the sky, not the sun's disc. (The sky's own light
//! through glass stays the field's, along its lines.) Photons are shot once per scene from
//! each kind of light at points drawn on the mirror and glass triangles (so every photon
//! reaches a delta surface; the pair's geometry term and a visibility test make its
//! power), carried through the delta
//! surfaces (each step choosing reflection or refraction by their weights), and stored
//! where they first reach a surface that is not delta. A pixel that sees such a surface
//! reads the photons' irradiance around its point on the same plane, where the field's
//! caustic part is left out of its remainder: their mean over the pixel's footprint (a
//! focused caustic is the pixel's mean, as the path tracer's, not its value at the
//! pixel's centre: that was twice as bright under the Cornell box's sphere), over a
//! footprint grown until it holds [`NEAREST`] photons where it holds fewer.

use glam::{IVec3, Vec2, Vec3};
use holocave_scene::color::luminance;
use holocave_scene::ray::surface_epsilon;
use holocave_scene::{PlacedScene, Ray, Scene};
use holocave_tracer::lights::Lights;
use rand::{Rng, SeedableRng, rngs::SmallRng};
use rayon::prelude::*;

use crate::footprint::Ellipse;
use crate::surface::{MAX_DELTA_DEPTH, delta_step, seen, seen_at};

/// Photons shot per kind of light (pairs of a light's sample and a delta-surface point;
/// those that do not see each other are lost).
pub const PHOTONS: usize = 1 << 20;

/// Photons an estimate averages: the relative noise of one is about `1/√NEAREST`.
pub const NEAREST: usize = 64;

/// The widest an estimate reaches, as a share of the scene's diagonal: where fewer than
/// [`NEAREST`] photons lie that close, those that do make the estimate.
pub const REACH: f32 = 0.01;

/// A photon stored where it reached a surface that is not delta.
#[derive(Clone, Copy, Debug)]
struct Photon {
    position: Vec3,
    /// The surface's face normal, on the side the photon arrived from.
    normal: Vec3,
    power: Vec3,
}

/// The photons of a scene, by cell of a grid over their bounds, its cells half an
/// estimate's reach (wider where that would make more than [`MOST_CELLS`]).
pub struct Caustics {
    photons: Vec<Photon>,
    /// The first photon of each cell (x fastest), and one past the last.
    starts: Vec<u32>,
    origin: Vec3,
    dims: IVec3,
    cell: f32,
    reach: f32,
}

/// The most cells the grid has (4 bytes each).
const MOST_CELLS: f32 = 8.0e6;

/// The static scene's mirror and glass triangles, chosen by area.
struct Targets {
    triangles: Vec<u32>,
    /// Running sums of their areas.
    cumulative: Vec<f32>,
}

impl Targets {
    fn of(scene: &Scene) -> Option<Targets> {
        let (mut triangles, mut cumulative, mut sum) = (Vec::new(), Vec::new(), 0.0f32);
        for t in 0..scene.triangle_count() as u32 {
            let third = 1.0 / 3.0;
            if seen_at(scene, t, third, third).delta {
                sum += scene.triangle_area(t);
                triangles.push(t);
                cumulative.push(sum);
            }
        }
        (sum > 0.0).then_some(Targets {
            triangles,
            cumulative,
        })
    }

    fn area(&self) -> f32 {
        self.cumulative.last().copied().unwrap_or(0.0)
    }

    /// A triangle by area (`uc`) and a point uniform on it (`u`).
    fn sample(&self, scene: &Scene, uc: f32, u: Vec2) -> (u32, Vec3) {
        let at = uc * self.area();
        let k = self
            .cumulative
            .partition_point(|&c| c <= at)
            .min(self.triangles.len() - 1);
        let t = self.triangles[k];
        let [a, b, c] = *scene.triangle(t);
        let s = u.x.sqrt();
        (t, a * (1.0 - s) + b * (s * (1.0 - u.y)) + c * (s * u.y))
    }
}

impl Caustics {
    /// The caustic map of `scene`'s static part, `photons` shot from each kind of light
    /// it has — its emitters, the sun, its punctual lights — (the same on any machine:
    /// each photon draws from its own seeded generator); `None` without mirrors and glass
    /// or without lights.
    pub fn trace(scene: &Scene, lights: &Lights, photons: usize) -> Option<Caustics> {
        let targets = Targets::of(scene)?;
        let placed = scene.statics();
        let (lo, hi) = scene.bounds();
        let diagonal = (hi - lo).length().max(f32::MIN_POSITIVE);
        let kinds = [
            lights.has_area().then_some(Kind::Emitters),
            lights.sun.is_some().then_some(Kind::Sun),
            (!lights.punctual.is_empty()).then_some(Kind::Punctual),
        ];
        let kinds: Vec<Light> = (kinds.into_iter().flatten())
            .map(|kind| Light {
                scene,
                lights,
                kind,
                diagonal,
            })
            .collect();
        if kinds.is_empty() || photons == 0 {
            return None;
        }
        let scale = 1.0 / photons as f32;
        // Photon `j` is the `j % photons`-th of kind `j / photons`, with its own generator.
        let stored: Vec<Photon> = (0..kinds.len() * photons)
            .into_par_iter()
            .filter_map(|j| {
                let light = &kinds[j / photons];
                let mut rng = SmallRng::seed_from_u64(j as u64 ^ 0x9e37_79b9_7f4a_7c15);
                shoot(scene, &placed, light, &targets, &mut rng).map(|mut p| {
                    p.power *= scale;
                    p
                })
            })
            .collect();
        Some(Caustics::of(stored, REACH * diagonal))
    }

    fn of(mut photons: Vec<Photon>, reach: f32) -> Caustics {
        let (lo, hi) = photons.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(p.position), hi.max(p.position)),
        );
        let size = (hi - lo).max(Vec3::ZERO);
        let volume = (size + reach).element_product();
        let cell = (reach / 2.0).max((volume / MOST_CELLS).cbrt());
        let dims = if photons.is_empty() {
            IVec3::ZERO
        } else {
            (size / cell).floor().as_ivec3() + 1
        };
        let index = |p: &Photon| {
            let c = ((p.position - lo) / cell)
                .floor()
                .as_ivec3()
                .clamp(IVec3::ZERO, dims - 1);
            (c.x + dims.x * (c.y + dims.y * c.z)) as usize
        };
        photons.sort_by_key(index);
        let cells = dims.element_product().max(0) as usize;
        let mut starts = vec![0u32; cells + 1];
        for p in &photons {
            starts[index(p) + 1] += 1;
        }
        for i in 0..cells {
            starts[i + 1] += starts[i];
        }
        Caustics {
            photons,
            starts,
            origin: lo,
            dims,
            cell,
            reach,
        }
    }

    /// The photons of cell `c` of the grid (none outside it).
    fn in_cell(&self, c: IVec3) -> &[Photon] {
        if c.cmplt(IVec3::ZERO).any() || c.cmpge(self.dims).any() {
            return &[];
        }
        let i = (c.x + self.dims.x * (c.y + self.dims.y * c.z)) as usize;
        &self.photons[self.starts[i] as usize..self.starts[i + 1] as usize]
    }

    /// How many photons are stored.
    pub fn len(&self) -> usize {
        self.photons.len()
    }

    pub fn is_empty(&self) -> bool {
        self.photons.is_empty()
    }

    /// The power all stored photons carry (W, as the scene's radiance units times m²·sr).
    pub fn power(&self) -> Vec3 {
        self.photons.iter().map(|p| p.power).sum()
    }

    /// The caustics' irradiance at `at` on a surface of face normal `normal` (either
    /// side): the photons' mean over `footprint` (a pixel's, clamped to
    /// [`FOOTPRINT_REACHES`] reaches) or, without one, over a disc an eighth of the
    /// reach across; where that holds fewer than [`NEAREST`] photons, over the same
    /// shape grown twofold until it does or reaches [`REACH`].
    pub fn irradiance(&self, at: Vec3, normal: Vec3, footprint: Option<Ellipse>) -> Vec3 {
        let widest = FOOTPRINT_REACHES * self.reach;
        let mut f = match footprint {
            Some(f) => Ellipse {
                along: f.along.min(widest),
                across: f.across.min(widest),
                ..f
            },
            None => Ellipse {
                centre: at,
                trace: normal.any_orthonormal_vector(),
                along: self.reach / 8.0,
                across: self.reach / 8.0,
            },
        };
        loop {
            let (sum, count) = self.sum_over(&f, normal);
            let largest = f.along.max(f.across);
            if count >= NEAREST || largest >= self.reach {
                return sum / f.area();
            }
            let grow = (self.reach / largest).min(2.0);
            f.along *= grow;
            f.across *= grow;
        }
    }

    /// The power of the photons in ellipse `f` on the plane of face normal `normal`
    /// (either side; not those of a corner's other wall or a thin slab's far side), and
    /// how many there are.
    fn sum_over(&self, f: &Ellipse, normal: Vec3) -> (Vec3, usize) {
        let across = normal.cross(f.trace).normalize_or_zero();
        let half = ((f.trace * f.along).powf(2.0) + (across * f.across).powf(2.0)).powf(0.5);
        let (lo, hi) = self.cells_of(f.centre - half, f.centre + half);
        // Where the box holds many more photons than an estimate needs, a share of each
        // cell's (its first: a cell's photons are in the order they were shot, at random),
        // weighted up by the share.
        let mut held = 0;
        self.each_cell(lo, hi, |c| held += c.len());
        let share = (SCANNED as f32 / held.max(1) as f32).min(1.0);
        let (mut sum, mut count) = (Vec3::ZERO, 0.0f32);
        self.each_cell(lo, hi, |c| {
            let taken = ((c.len() as f32 * share).ceil() as usize).min(c.len());
            let weight = c.len() as f32 / taken.max(1) as f32;
            for p in &c[..taken] {
                let on_plane = p.normal.dot(normal).abs() > 0.9
                    && normal.dot(p.position - f.centre).abs() < 0.05 * self.reach;
                if on_plane && f.contains(p.position) {
                    sum += p.power * weight;
                    count += weight;
                }
            }
        });
        (sum, count as usize)
    }

    /// The first and last cell of the grid that the box from `lo` to `hi` touches.
    fn cells_of(&self, lo: Vec3, hi: Vec3) -> (IVec3, IVec3) {
        (
            ((lo - self.origin) / self.cell)
                .floor()
                .as_ivec3()
                .max(IVec3::ZERO),
            ((hi - self.origin) / self.cell)
                .floor()
                .as_ivec3()
                .min(self.dims - 1),
        )
    }

    /// Calls `f` with the photons of every cell from `lo` to `hi`.
    fn each_cell(&self, lo: IVec3, hi: IVec3, mut f: impl FnMut(&[Photon])) {
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                for x in lo.x..=hi.x {
                    f(self.in_cell(IVec3::new(x, y, z)));
                }
            }
        }
    }
}

/// The most photons one step of an estimate looks at: where its box holds more, it takes
/// a share of each cell's.
const SCANNED: usize = 16 * NEAREST;

/// A footprint is clamped to this many reaches along each axis (a floor seen at a grazing
/// angle stretches a pixel's footprint far along the view).
pub const FOOTPRINT_REACHES: f32 = 4.0;

/// The lights photons are shot from, a kind at a time: only these reach a surface through
/// mirrors and glass without the walls or the field holding it already (the emitters'
/// part is the field's caustic part, which the walls then leave out; the sun's and the
/// punctual lights' are in neither: their shadow rays stop at glass and mirrors, and the
/// field's lines carry the sky, not the sun's disc).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Emitters,
    Sun,
    Punctual,
}

struct Light<'a> {
    scene: &'a Scene,
    lights: &'a Lights,
    kind: Kind,
    /// The scene's diagonal: a ray from beyond it stands for the sun's.
    diagonal: f32,
}

impl Light<'_> {
    /// Where a photon towards `target` starts, its unit direction and the distance to the
    /// target, and its power there over the target's area (the light's radiance or
    /// intensity, the geometry, the density of the light's sample; the target's cosine
    /// and density are the caller's); `None` where it sends nothing that way.
    fn towards(&self, target: Vec3, rng: &mut SmallRng) -> Option<(Vec3, Vec3, f32, Vec3)> {
        match self.kind {
            Kind::Emitters => {
                let (uc, u) = (rng.random(), Vec2::new(rng.random(), rng.random()));
                let light = self.lights.sample_area_point(uc, u)?;
                let to = target - light.position;
                let dist = to.length();
                let dir = to / dist;
                let facing = light.normal.dot(dir);
                let cos = if light.double_sided {
                    facing.abs()
                } else {
                    facing
                };
                let from = light.position
                    + light.normal * (surface_epsilon(light.position) * facing.signum());
                (dist > 0.0 && cos > 0.0).then(|| {
                    let power = light.emission(self.scene) * (cos / (dist * dist * light.density));
                    (from, dir, dist, power)
                })
            }
            Kind::Sun => {
                let ls = self
                    .lights
                    .sample_sun(Vec2::new(rng.random(), rng.random()))?;
                let from = target + ls.wi * self.diagonal;
                Some((from, -ls.wi, self.diagonal, ls.contribution))
            }
            Kind::Punctual => {
                let n = self.lights.punctual.len();
                let i = ((rng.random::<f32>() * n as f32) as usize).min(n - 1);
                let ls = self.lights.sample_punctual(i, target)?;
                let dist = ls.dist.min(self.diagonal);
                let from = target + ls.wi * dist;
                Some((from, -ls.wi, dist, ls.contribution * n as f32))
            }
        }
    }
}

/// One photon: a point on a mirror or glass triangle and a light's sample towards it
/// drawn, its power from the pair's geometry (unscaled by the photon count), carried
/// through the delta surfaces to the first that is not; `None` where the two do not see
/// each other or the photon is lost.
fn shoot(
    scene: &Scene,
    placed: &PlacedScene,
    light: &Light,
    targets: &Targets,
    rng: &mut SmallRng,
) -> Option<Photon> {
    let (t, target) = targets.sample(scene, rng.random(), Vec2::new(rng.random(), rng.random()));
    let (from, dir, dist, power) = light.towards(target, rng)?;
    let cos_target = scene.face_normal(t).dot(dir).abs();
    if cos_target <= 0.0 {
        return None;
    }
    let hit = placed.closest_hit(&Ray::new(from, dir), dist * 1.01)?;
    if hit.triangle != t {
        return None;
    }
    let mut power = power * (cos_target * targets.area());
    let mut s = seen(placed, hit, dir);
    let mut dir = dir;
    for _ in 0..MAX_DELTA_DEPTH {
        let ((wi, w), weaker) = delta_step(&s, dir)?;
        dir = match weaker {
            Some((wj, wk)) => {
                let p = luminance(w) / (luminance(w) + luminance(wk)).max(f32::MIN_POSITIVE);
                if rng.random::<f32>() < p {
                    power *= w / p;
                    wi
                } else {
                    power *= wk / (1.0 - p);
                    wj
                }
            }
            None => {
                power *= w;
                wi
            }
        };
        let hit = placed.closest_hit(&Ray::leaving(s.position, s.normal, dir), f32::INFINITY)?;
        s = seen(placed, hit, dir);
        if !s.delta {
            return (power.max_element() > 0.0).then(|| Photon {
                position: s.position,
                normal: if s.normal.dot(dir) < 0.0 {
                    s.normal
                } else {
                    -s.normal
                },
                power,
            });
        }
    }
    None
}
