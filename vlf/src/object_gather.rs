//! A moving object's own indirect light, gathered per pixel (stage 4 of the wall pass, beside
//! the direct light: [`crate::wall_pass`]).
//!
//! The light field holds the static scene only, so nothing in it knows what lights a moving
//! object's surface beyond the sun and the lamps (which [`crate::pixel_direct`] gives
//! exactly). One irradiance probe at the object's centre ([`crate::probe`]) sees the
//! static room *through* the object: a cabinet put in the shade beside a sunlit patch gets
//! the patch and the window on its top as on its sides, and the chair does not shade
//! itself. Here each of an object's pixels gathers instead, from its own surface point:
//! [`FIRST_GATHER_RAYS`] cosine-weighted rays in each of its first estimates at a point,
//! [`GATHER_RAYS`] in each later one (a frame's), into the scene as the frame places it
//! (the static scene, every object, the object itself), each ending on
//!
//! - a **static surface**: the light field's light there towards the ray (all of it, its
//!   direct light as baked: its lookup of elements and tiles, what mirrors and glass
//!   show), darkened by the objects as [`crate::objects`]' sphere darkens the field beside
//!   them (the floor the block hides a window from; measured: the block in the shade +7 %
//!   without it, +2.2 % with it, after 32 frames). Taking that point's own direct light
//!   with shadow rays instead was measured no closer (the floor there is lit by the window
//!   and the room, not the sun) and costs shadow rays;
//! - a **moving object** (itself or another): its point's exact direct light, and its
//!   indirect light from its probe (the probe's error enters once more reflected, times an
//!   albedo);
//! - **nothing**: the sky, unless the sky is sampled per pixel (then the point's own
//!   next-event estimate takes it); never the sun's disc or an emitter, which the point's
//!   direct light takes.
//!
//! **Beside an object** a static point whose hemisphere the objects take much of
//! ([`crate::view::GATHERED_OCCLUSION`]) keeps the field's lookup, undarkened, and gathers
//! only what the objects change of it: each ray brings what it meets with the objects
//! placed less what the field alone brings along it ([`ObjectGather::estimate`]), so a ray
//! that meets neither an object nor a surface beside one adds exactly nothing.
//!
//! Its irradiance is `π/N Σ L`, and the light towards the eye the surface's directional
//! albedo over `π` times that ([`DirectPoint::albedo`], as a Lambertian surface's). The
//! estimates join the direct light's in the pixel's running mean at its surface point
//! ([`crate::Accumulator`]): a still object converges over frames as a still view's
//! penumbrae do, and a moved object's pixels start again (their points moved).

use glam::{Vec2, Vec3};
use holocave_scene::{Hit, PlacedScene, Ray};
use holocave_tracer::frame::Frame;
use holocave_tracer::sampling::cosine_hemisphere;

use crate::pixel_direct::{DirectPoint, PixelDirect};
use crate::sequence::{R2, r_sequence};
use crate::surface::{albedo_towards, seen};
use crate::view::Visibility;

/// Rays each estimate at an object's point gathers after its first frame there.
pub const GATHER_RAYS: u64 = 4;

/// Rays each of the estimates a pixel takes at a new point of an object gathers
/// ([`PixelDirect::first_estimates`] of them): an object newly in sight, or moved, is
/// drawn from these alone. A static point beside an object takes [`GATHER_RAYS`] in every
/// estimate: it gathers only what the object changes over the field's light, and the first
/// frame of a wall with the room's block in view took 155 ms with 16 there, 85 ms with 4
/// (at 128 × 96 on two cores; the worst 16 × 16 block beside the block 9.8 % and 16.7 %
/// off the path tracer), and a moving object's neighbours start again every frame.
pub const FIRST_GATHER_RAYS: u64 = 16;

/// The dimension of the R sequence the gathers' directions take (their own: never in step
/// with the lights' samples).
const DIRECTIONS: i32 = 5;

/// What a moving object's pixels, and the static ones beside it, gather: the scene's
/// visibility, the direct light taken at the objects' points the rays end on, and all of
/// the light field's light.
#[derive(Clone, Copy)]
pub struct ObjectGather<'a> {
    pub visibility: &'a Visibility,
    pub direct: &'a PixelDirect,
    pub values: &'a [[f32; 3]],
}

impl ObjectGather<'_> {
    /// The `n`-th estimate of pixel `seed`'s indirect light towards the eye at `p`, with
    /// the objects where `placed` puts them (`p.weight` included), where `p`'s is gathered
    /// ([`DirectPoint::gathered`]): all of it on an object, what the objects change of
    /// the field's on a static point beside one; zero elsewhere (the light field's lookup
    /// gives it).
    pub fn estimate(&self, placed: &PlacedScene, p: &DirectPoint, seed: u64, n: u64) -> Vec3 {
        if !p.gathered {
            return Vec3::ZERO;
        }
        let facing = |v: Vec3| if v.dot(p.wo) < 0.0 { -v } else { v };
        let (normal, frame) = (facing(p.normal), Frame::new(facing(p.shading_normal)));
        let on_object = placed.object_of(p.triangle).is_some();
        let (first, rays) = if on_object {
            self.rays_of(n)
        } else {
            (n * GATHER_RAYS, GATHER_RAYS)
        };
        let mut sum = Vec3::ZERO;
        for i in first..first + rays {
            let u = Vec2::new(
                r_sequence(R2, DIRECTIONS, 0, i, seed),
                r_sequence(R2, DIRECTIONS, 1, i, seed),
            );
            let d = frame.to_world(cosine_hemisphere(u));
            if d.dot(normal) <= 0.0 {
                continue;
            }
            let ray = Ray::leaving(p.position, normal, d);
            sum += if on_object {
                self.arriving(placed, ray, (seed, i))
            } else {
                self.changed(placed, ray, (seed, i))
            };
        }
        p.weight * p.albedo * sum / rays as f32
    }

    /// The rays of the `n`-th estimate: their first index in the pixel's sequence and how
    /// many, [`FIRST_GATHER_RAYS`] for each first estimate, then [`GATHER_RAYS`].
    fn rays_of(&self, n: u64) -> (u64, u64) {
        let first = u64::from(self.direct.first_estimates());
        if n < first {
            (n * FIRST_GATHER_RAYS, FIRST_GATHER_RAYS)
        } else {
            (
                first * FIRST_GATHER_RAYS + (n - first) * GATHER_RAYS,
                GATHER_RAYS,
            )
        }
    }

    /// The radiance arriving along `ray` that the gathering point's own direct light does
    /// not take, with the objects where `placed` puts them; `at` names the estimate taken
    /// where the ray ends.
    fn arriving(&self, placed: &PlacedScene, ray: Ray, at: (u64, u64)) -> Vec3 {
        let statics = placed.scene().closest_hit(&ray, f32::INFINITY);
        let first = placed.objects_closest_hit(&ray, f32::INFINITY, statics);
        self.arriving_at(placed, ray, (statics, first), at)
    }

    /// What the objects change of [`Self::arriving`]: it less what the light field alone
    /// brings along `ray` (nothing where the ray meets neither an object nor a surface
    /// beside one).
    fn changed(&self, placed: &PlacedScene, ray: Ray, at: (u64, u64)) -> Vec3 {
        let statics = placed.scene().closest_hit(&ray, f32::INFINITY);
        let first = placed.objects_closest_hit(&ray, f32::INFINITY, statics);
        if first.is_none() {
            return Vec3::ZERO;
        }
        self.arriving_at(placed, ray, (statics, first), at) - self.unplaced(ray, statics)
    }

    /// [`Self::arriving`] where the ray's first hit in the static scene and among the
    /// objects are known.
    fn arriving_at(
        &self,
        placed: &PlacedScene,
        ray: Ray,
        (statics, first): (Option<Hit>, Option<Hit>),
        (seed, i): (u64, u64),
    ) -> Vec3 {
        let Some(first) = first else {
            return self.unplaced(ray, None);
        };
        let Some(k) = placed.object_of(first.triangle) else {
            return (self.visibility).arriving_darkened(ray, statics, self.values);
        };
        // Past its first estimates, so that each end takes one sample of each light.
        let n = i + u64::from(self.direct.first_estimates());
        let s = seen(placed, first, ray.dir);
        let q = s.direct_point(-ray.dir, Vec3::ONE);
        let facing = if s.shading_normal.dot(ray.dir) > 0.0 {
            -s.shading_normal
        } else {
            s.shading_normal
        };
        let probe = self.visibility.object_irradiance(k, facing);
        albedo_towards(&s.params, s.shading_normal.dot(ray.dir))
            * std::f32::consts::FRAC_1_PI
            * probe
            + self.direct.estimate(placed, &q, seed, n).radiance
    }

    /// What the light field alone brings along `ray`, whose first static hit is
    /// `statics`: the sky where it leaves, unless the sky is taken per pixel.
    fn unplaced(&self, ray: Ray, statics: Option<Hit>) -> Vec3 {
        if statics.is_none() && self.direct.samples_sky() {
            return Vec3::ZERO;
        }
        (self.visibility)
            .arriving_from(ray, statics, self.values)
            .radiance
    }
}
