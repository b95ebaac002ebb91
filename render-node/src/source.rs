//! Where samples come from: the chosen pixels of an eye become jittered eye rays, traced
//! by the path tracer, and come back as [`NewSample`]s. (The holodeck server is the other
//! intended source; see the crate's notes.)

use std::sync::Arc;

use glam::Vec2;
use holocave_scene::Ray;
use holocave_tracer::Tracer;
use rand::{Rng, SeedableRng, rngs::SmallRng};
use rayon::prelude::*;

use crate::EyeView;
use crate::cache::{BACKGROUND, NewSample};

/// Escaped rays are placed this far along the ray (m) and marked [`BACKGROUND`].
pub const BACKGROUND_DISTANCE: f32 = 1000.0;

/// Traces the pixels an eye asks for, on the calling thread pool.
pub struct TracerSource {
    tracer: Arc<Tracer>,
    rng: SmallRng,
    seed: u64,
}

impl TracerSource {
    pub fn new(tracer: Arc<Tracer>, seed: u64) -> Self {
        TracerSource {
            tracer,
            rng: SmallRng::seed_from_u64(seed),
            seed,
        }
    }

    /// One sample per chosen pixel (index `y * width + x`), through a random point of the
    /// pixel so that a still view converges to the pixel's mean, as `holocave render`.
    pub fn sample(&mut self, view: &EyeView, pixels: &[u32]) -> Vec<NewSample> {
        let w = view.wall.width;
        let rays: Vec<Ray> = pixels
            .iter()
            .map(|&p| {
                let (x, y) = (p % w, p / w);
                let j = Vec2::new(self.rng.random(), self.rng.random());
                view.wall.ray(Vec2::new(x as f32, y as f32) + j)
            })
            .collect();
        self.seed = self.seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let samples = self.tracer.trace(&rays, self.seed);
        let scene = self.tracer.scene();
        rays.par_iter()
            .zip(samples.par_iter())
            .zip(pixels.par_iter())
            .with_min_len(64)
            .map(|((ray, s), &pixel)| {
                let (distance, surface) = if s.distance.is_finite() {
                    let surface = scene
                        .closest_hit(ray, f32::INFINITY)
                        .map(|h| scene.surface(&h).material)
                        .unwrap_or(BACKGROUND);
                    (s.distance, surface)
                } else {
                    (BACKGROUND_DISTANCE, BACKGROUND)
                };
                NewSample::new(
                    pixel,
                    ray.origin,
                    ray.at(distance),
                    distance,
                    s.radiance,
                    surface,
                )
            })
            .collect()
    }
}
