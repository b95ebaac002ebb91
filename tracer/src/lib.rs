//! The sample generator of holocave: for each ray, the radiance arriving along it, the
//! distance to what it hits, and the virtual distance seen through flat mirrors and glass.
//! In the holodeck paper this is Radiance's `rtrace`.
//!
//! - [`integrator`]: the path tracer (NEE + MIS, Russian roulette, virtual distance);
//! - [`bsdf`], [`microfacet`], [`fresnel`]: glTF's metallic-roughness scattering;
//! - [`lights`]: what next-event estimation samples ([`few_lights`] and [`light_groups`]:
//!   which lamp, by place), and [`mirrors`]: the same through flat mirrors;
//! - [`film`]: the images wall views (`holocave_cave::WallView`) make;
//! - [`holodeck`]: the tracer as the holodeck's sample source, and [`cave_holodeck`]: a
//!   CAVE's holodeck file and its server (open or create, serve, host for a cluster).

pub mod bsdf;
pub mod cave_holodeck;
pub mod few_lights;
pub mod film;
pub mod frame;
pub mod fresnel;
pub mod holodeck;
pub mod integrator;
pub mod light_groups;
pub mod lights;
pub mod microfacet;
pub mod mirrors;
pub mod render;
pub mod sampling;

use std::sync::Arc;

use holocave_scene::bvh::PACKET;
use holocave_scene::{Ray, Scene};
use rand::SeedableRng;
use rand_pcg::Pcg32;
use rayon::prelude::*;

use crate::integrator::PathStart;
use crate::lights::Lights;

/// What the tracer answers for one ray: the radiance along it and its hit distances.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TracedRay {
    /// Linear RGB radiance arriving along the ray (towards its origin). Never NaN or Inf.
    pub radiance: [f32; 3],
    /// Distance along the ray to the first hit; infinite if the ray escapes.
    pub distance: f32,
    /// Distance to the first non-specular surface, continuing through flat mirrors and
    /// flat glass (the holodeck paper's `VDISTANCE`); infinite if the path escapes first.
    pub virtual_distance: f32,
    /// The material of the first hit (an index into the scene's materials); `None` if the
    /// ray escapes. A render cache marks its samples with it.
    pub material: Option<u32>,
}

impl TracedRay {
    /// The answer for a ray that cannot be traced (zero, NaN or infinite direction or
    /// origin): no radiance, nothing hit.
    pub const NONE: TracedRay = TracedRay {
        radiance: [0.0; 3],
        distance: f32::INFINITY,
        virtual_distance: f32::INFINITY,
        material: None,
    };
}

/// Rays whose first hits are found together: a few packets, small enough to spread over
/// the threads.
const BATCH: usize = 4 * PACKET;

/// Path length limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceSettings {
    /// A hard cap on bounces; Russian roulette ends paths long before it.
    pub max_depth: u32,
    /// The bounce from which Russian roulette may end a path.
    pub roulette_depth: u32,
}

impl Default for TraceSettings {
    fn default() -> Self {
        Self {
            max_depth: 64,
            roulette_depth: 3,
        }
    }
}

/// A path tracer bound to one scene.
pub struct Tracer {
    scene: Arc<Scene>,
    lights: Lights,
    settings: TraceSettings,
}

/// The random stream of ray `index` in a batch traced with `seed` (SplitMix64 finaliser,
/// so neighbouring indices get unrelated streams).
fn ray_rng(seed: u64, index: u64) -> Pcg32 {
    let mut z = seed ^ index.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    Pcg32::seed_from_u64(z ^ (z >> 31))
}

impl Tracer {
    pub fn new(scene: Arc<Scene>, settings: TraceSettings) -> Self {
        let lights = Lights::new(&scene);
        Self {
            scene,
            lights,
            settings,
        }
    }

    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    pub fn settings(&self) -> TraceSettings {
        self.settings
    }

    /// One sample per ray, on all cores. The result depends only on the rays and `seed`.
    /// Rays next to each other should be coherent (neighbouring pixels, one beam): their
    /// first hits are found together (see [`Scene::closest_hits`]).
    pub fn trace(&self, rays: &[Ray], seed: u64) -> Vec<TracedRay> {
        let mut out = vec![TracedRay::NONE; rays.len()];
        out.par_chunks_mut(BATCH)
            .zip(rays.par_chunks(BATCH))
            .enumerate()
            .for_each(|(c, (out, rays))| self.trace_batch(rays, seed, c * BATCH, out));
        out
    }

    /// As [`Tracer::trace`], on the calling thread only (for workers that own a core).
    pub fn trace_serial(&self, rays: &[Ray], seed: u64) -> Vec<TracedRay> {
        let mut out = vec![TracedRay::NONE; rays.len()];
        for (c, (out, rays)) in out.chunks_mut(BATCH).zip(rays.chunks(BATCH)).enumerate() {
            self.trace_batch(rays, seed, c * BATCH, out);
        }
        out
    }

    /// Rays `first..` of a batch traced with `seed`: the first hits of the rays that reach
    /// the scene found in packets, then each path on its own.
    fn trace_batch(&self, rays: &[Ray], seed: u64, first: usize, out: &mut [TracedRay]) {
        let (scene, lights) = (&*self.scene, &self.lights);
        let starts: Vec<PathStart> = rays
            .iter()
            .map(|r| integrator::start_path(scene, lights, r))
            .collect();
        let entering: Vec<Ray> = starts
            .iter()
            .filter_map(|s| match s {
                PathStart::Trace { ray, .. } => Some(*ray),
                PathStart::Done(_) => None,
            })
            .collect();
        let mut first_hits = scene.closest_hits(&entering, f32::INFINITY).into_iter();
        for (i, (start, out)) in starts.into_iter().zip(out).enumerate() {
            *out = match start {
                PathStart::Done(sample) => sample,
                PathStart::Trace { ray, skipped } => {
                    let hit = first_hits.next().flatten();
                    let mut rng = ray_rng(seed, (first + i) as u64);
                    integrator::finish_path(
                        scene,
                        lights,
                        &self.settings,
                        ray,
                        skipped,
                        hit,
                        &mut rng,
                    )
                }
            };
        }
    }

    /// The sample of ray `index` of a batch traced with `seed`.
    pub fn trace_one(&self, ray: &Ray, seed: u64, index: u64) -> TracedRay {
        let mut rng = ray_rng(seed, index);
        integrator::trace_path(&self.scene, &self.lights, &self.settings, ray, &mut rng)
    }
}
