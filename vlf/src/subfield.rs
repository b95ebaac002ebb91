//! Parallel subfields: for one line orientation `d`, an `N × N` grid of parallel lines
//! covering the scene's bounding sphere, each with every surface it crosses, in order.
//!
//! A line is bi-directional: light travels along it both ways. At each crossing the line
//! knows the element on each side of the surface (`minus`: the side facing `−d`, where
//! light travelling along `+d` arrives; `plus`: the side facing `+d`). A delta surface
//! (mirror, smooth glass) stores no irradiance: for each way along the line it stores a
//! [`Link`] to the diffuse element seen through it, found by following the reflected or
//! refracted ray exactly (so mirrors are sharp, not blurred by the direction spacing).
//!
//! Lines that cross nothing are not stored: a direction whose lines miss the scene costs
//! nothing after the visibility pass. Each line lies at its own random place within its
//! cell of the grid (a jittered grid, different in every subfield): a regular lattice of
//! lines aliases against the elements into moiré streaks along the direction; jittered,
//! the aliasing becomes noise that the other directions average out.

use glam::Vec3;
use holocave_scene::{Hit, Ray, Scene, surface_epsilon};
use holocave_tracer::frame::Frame;

use crate::elements::Elements;
use crate::surface::{follow, seen, side_facing};

/// Marks a crossing's side as a delta surface: the low bits index the subfield's links.
pub const DELTA: u32 = 1 << 31;

/// One surface a line crosses: the element (or link, with [`DELTA`]) on each side.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Crossing {
    pub minus: u32,
    pub plus: u32,
}

/// What a delta surface sends along a line: `weight ×` the outgoing radiance of
/// `element` (none: `u32::MAX`) in direction `toward` (the way the light leaves it, back
/// along the followed ray: what a glossy element's tile is read in), plus `emitted`
/// (emitters, the sky and the sun seen through the delta surfaces; first bounce only).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Link {
    pub element: u32,
    pub weight: Vec3,
    pub emitted: Vec3,
    pub toward: Vec3,
}

/// One direction's lines.
#[derive(Clone, Debug, Default)]
pub struct Subfield {
    /// For each stored line, its first crossing in `crossings`; one more at the end.
    pub line_start: Vec<u32>,
    pub crossings: Vec<Crossing>,
    pub links: Vec<Link>,
    /// Lines that cross the sphere (stored or not): the subfield's share of the work.
    pub lines_cast: u32,
}

/// The bounding sphere the subfields cover: the scene's box's.
#[derive(Clone, Copy, Debug)]
pub struct Sphere {
    pub centre: Vec3,
    pub radius: f32,
}

impl Sphere {
    pub fn of(scene: &Scene) -> Sphere {
        let (lo, hi) = scene.bounds();
        Sphere {
            centre: (lo + hi) * 0.5,
            radius: (hi - lo).length() * 0.5 * 1.001 + 1e-6,
        }
    }
}

/// A number in [0, 1) from a subfield's index and a salt (SplitMix64).
fn jitter(index: u32, salt: u64) -> f32 {
    let mut z = ((u64::from(index) << 40) ^ salt).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
}

/// The grid of one subfield: where line `(i, j)` starts, and the spacing.
#[derive(Clone, Copy, Debug)]
pub struct Grid {
    pub frame: Frame,
    pub sphere: Sphere,
    pub n: u32,
    pub spacing: f32,
    /// Tangent of the angle by which a line may lean from the subfield's direction.
    pub lean: f32,
    index: u32,
}

impl Grid {
    /// The cross-section a line stands for, on average: lines `spacing` apart across the
    /// subfield's direction, leaning by `α`, are `spacing² cos α` apart across their own;
    /// with the tangent of `α` uniform over a disc of radius `T`, the mean of `cos α` is
    /// `2(√(1 + T²) − 1)/T²`.
    pub fn cross_section(&self) -> f32 {
        let t2 = self.lean * self.lean;
        let mean_cos = if t2 > 0.0 {
            2.0 * ((1.0 + t2).sqrt() - 1.0) / t2
        } else {
            1.0
        };
        self.spacing * self.spacing * mean_cos
    }

    /// The grid of direction `d`, whose lines lean from it by up to the angular radius
    /// of the `solid_angle` it stands for.
    pub fn new(d: Vec3, index: u32, sphere: Sphere, n: u32, solid_angle: f32) -> Grid {
        Grid {
            frame: Frame::new(d),
            sphere,
            n,
            spacing: 2.0 * sphere.radius / n as f32,
            lean: (solid_angle / std::f32::consts::PI).sqrt().tan(),
            index,
        }
    }

    /// Line `(i, j)` as a ray entering the sphere, or `None` outside the sphere's disc.
    pub fn line(&self, i: u32, j: u32) -> Option<Ray> {
        let r = self.sphere.radius;
        // Each line at its own random place in its cell (a jittered grid).
        let cell = u64::from(j) * u64::from(self.n) + u64::from(i);
        let salt = cell.wrapping_mul(4).wrapping_add(1);
        let x = -r + (i as f32 + jitter(self.index, salt)) * self.spacing;
        let y = -r + (j as f32 + jitter(self.index, salt + 1)) * self.spacing;
        if x * x + y * y > r * r {
            return None;
        }
        // ... and with its own direction within the direction's cone (uniform over the
        // disc of tangents): a small bright patch seen along one exact direction would
        // light a sharp stripe, its projection; leaning lines blur the stripes into noise
        // that other directions average out.
        let (u, v) = (jitter(self.index, salt + 2), jitter(self.index, salt + 3));
        let (rho, phi) = (self.lean * u.sqrt(), std::f32::consts::TAU * v);
        let f = &self.frame;
        let dir = (f.n + f.t * (rho * phi.cos()) + f.b * (rho * phi.sin())).normalize();
        let through = self.sphere.centre + f.t * x + f.b * y;
        Some(Ray::new(through - dir * (r * 1.01), dir))
    }
}

/// Casts every line of subfield `index` (orientation `d`) and records its crossings.
/// `environment(dir)` is the light of the sky and sun looking along `dir`.
pub fn cast(
    scene: &Scene,
    elements: &Elements,
    grid: &Grid,
    environment: &dyn Fn(Vec3) -> Vec3,
) -> Subfield {
    let mut out = Subfield::default();
    // The light field is of the static scene: moving objects are never baked.
    let statics = scene.statics();
    let tmax = grid.sphere.radius * 2.1;
    let mut hits: Vec<Hit> = Vec::new();
    out.line_start.push(0);
    for j in 0..grid.n {
        for i in 0..grid.n {
            let Some(ray) = grid.line(i, j) else { continue };
            let d = ray.dir;
            out.lines_cast += 1;
            scene.all_hits(&ray, tmax, &mut hits);
            let first = out.crossings.len();
            let mut last_t = f32::NEG_INFINITY;
            for h in &hits {
                // Two triangles meeting at an edge the line runs through are one surface:
                // hits closer than a tenth of the gap a new ray leaves off a surface.
                let p = ray.at(h.t);
                if h.t - last_t <= 0.1 * surface_epsilon(p) {
                    continue;
                }
                last_t = h.t;
                let s = seen(&statics, *h, d);
                let minus = side_facing(s.normal, d);
                let plus = 1 - minus;
                let crossing = if s.delta {
                    // Light leaving along +d comes from what a ray arriving along −d sees.
                    let mut link = |arriving: Vec3| {
                        // Started back along the line by four surface gaps, so that it
                        // meets this surface again even where the line grazes it.
                        let probe = Ray::new(p - arriving * (4.0 * surface_epsilon(p)), arriving);
                        let chain = follow(&statics, probe, environment);
                        let (element, emitted, toward) = match chain.end {
                            Some((end, r)) => (
                                elements.element(
                                    end.hit.triangle,
                                    side_facing(end.normal, r.dir),
                                    end.hit.u,
                                    end.hit.v,
                                ),
                                chain.emitted + chain.weight * end.emitted,
                                -r.dir,
                            ),
                            None => (u32::MAX, chain.emitted, Vec3::ZERO),
                        };
                        out.links.push(Link {
                            element,
                            weight: chain.weight,
                            emitted,
                            toward,
                        });
                        DELTA | (out.links.len() as u32 - 1)
                    };
                    Crossing {
                        plus: link(-d),
                        minus: link(d),
                    }
                } else {
                    Crossing {
                        minus: elements.element(h.triangle, minus, h.u, h.v),
                        plus: elements.element(h.triangle, plus, h.u, h.v),
                    }
                };
                out.crossings.push(crossing);
            }
            if out.crossings.len() > first {
                out.line_start.push(out.crossings.len() as u32);
            }
        }
    }
    out
}
