//! Samples traced by the node itself: the chosen pixels of an eye become jittered eye
//! rays, traced by the path tracer, and come back as [`NewSample`]s. (The other source is
//! a holodeck server: [`crate::feed::holodeck`].)

use std::sync::Arc;

use glam::{Vec2, Vec3};
use holocave_scene::{MaterialKind, Ray};
use holocave_tracer::Tracer;
use rand::{Rng, SeedableRng, rngs::SmallRng};

use crate::cache::{BACKGROUND, NewSample, SampleSurface, surface_id};
use crate::{EyeView, VlfBase};

/// Escaped rays are placed this far along the ray (m) and marked [`BACKGROUND`].
pub const BACKGROUND_DISTANCE: f32 = 1000.0;

/// Traces the pixels an eye asks for, on the calling thread pool.
pub struct PixelTracer {
    tracer: Arc<Tracer>,
    rng: SmallRng,
    seed: u64,
    /// Paths averaged into each sample.
    paths: u32,
    /// Per material, whether it is Lambertian (what it sends is the same seen from
    /// anywhere, so its samples are marked view-independent).
    lambertian: Vec<bool>,
    /// Gather samples over this light field instead of full paths ([`Self::with_gather`]).
    gather: Option<Arc<VlfBase>>,
}

/// What one sample of an eye ray found: radiance, first-hit distance, its material and
/// what it saw of the moving objects (only gathers see them where they stand).
struct Traced {
    radiance: Vec3,
    distance: f32,
    material: Option<u32>,
    seen: SampleSurface,
}

impl PixelTracer {
    pub fn new(tracer: Arc<Tracer>, seed: u64) -> Self {
        let lambertian = (tracer.scene().materials.iter())
            .map(|m| m.kind() == MaterialKind::Diffuse)
            .collect();
        PixelTracer {
            tracer,
            rng: SmallRng::seed_from_u64(seed),
            seed,
            paths: 1,
            lambertian,
            gather: None,
        }
    }

    /// Samples that end in `base` after one bounce, the direct light exact at both points
    /// ([`VlfBase::gather`]), instead of full paths: far less variance, and the light
    /// field's error only after a bounce.
    pub fn with_gather(mut self, base: Arc<VlfBase>) -> Self {
        self.gather = Some(base);
        self
    }

    /// Whether the samples are gathers over a light field.
    pub fn gathers(&self) -> bool {
        self.gather.is_some()
    }

    /// One sample along each ray, from stream `seed`: a gather, or a full path.
    fn trace(&self, rays: &[Ray], seed: u64) -> Vec<Traced> {
        match &self.gather {
            Some(base) => base
                .gather(rays, seed)
                .into_iter()
                .map(|g| Traced {
                    radiance: g.radiance,
                    distance: g.distance,
                    material: g.material,
                    seen: match (g.object, g.object_beyond) {
                        (Some(k), _) => SampleSurface::Object(k),
                        (None, true) => SampleSurface::ObjectBeyond,
                        (None, false) => SampleSurface::Scene,
                    },
                })
                .collect(),
            None => self
                .tracer
                .trace(rays, seed)
                .into_iter()
                .map(|t| Traced {
                    radiance: Vec3::from(t.radiance),
                    distance: t.distance,
                    material: t.material,
                    seen: SampleSurface::Scene,
                })
                .collect(),
        }
    }

    /// The samples of stream `seed` along each ray (for measuring their variance).
    pub fn radiance(&self, rays: &[Ray], seed: u64) -> Vec<Vec3> {
        self.trace(rays, seed)
            .into_iter()
            .map(|t| t.radiance)
            .collect()
    }

    /// Each sample the mean of `paths` paths from its eye ray (at least one): how a
    /// budget of more rays than an eye has pixels is spent, since the cache takes at most
    /// one sample per pixel and frame.
    pub fn with_paths(mut self, paths: u32) -> Self {
        self.paths = paths.max(1);
        self
    }

    /// One sample per chosen pixel (index `y * width + x`), through a random point of the
    /// pixel so that a still view converges to the pixel's mean, as `holocave render`.
    pub fn sample(&mut self, view: &EyeView, pixels: &[u32]) -> Vec<NewSample> {
        let w = view.wall.size.width;
        let rays: Vec<Ray> = pixels
            .iter()
            .map(|&p| {
                let (x, y) = (p % w, p / w);
                let j = Vec2::new(self.rng.random(), self.rng.random());
                view.wall.ray(Vec2::new(x as f32, y as f32) + j)
            })
            .collect();
        self.seed = self.seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut samples = self.trace(&rays, self.seed);
        if self.paths > 1 {
            // More samples of the same eye rays (their first hit, hence distance, is the
            // same), averaged.
            for k in 1..self.paths {
                let more = self.radiance(&rays, self.seed ^ (u64::from(k) << 40));
                for (s, m) in samples.iter_mut().zip(more) {
                    s.radiance += m;
                }
            }
            for s in &mut samples {
                s.radiance /= self.paths as f32;
            }
        }
        rays.iter()
            .zip(&samples)
            .zip(pixels)
            .map(|((ray, s), &pixel)| {
                let (distance, material, surface) = match s.material {
                    Some(m) if s.distance.is_finite() => {
                        (s.distance, Some(m), surface_id(m, s.seen))
                    }
                    _ => (BACKGROUND_DISTANCE, None, BACKGROUND),
                };
                let sample = NewSample::new(
                    pixel,
                    ray.origin,
                    ray.at(distance),
                    distance,
                    s.radiance.to_array(),
                    surface,
                );
                match material.and_then(|m| self.lambertian.get(m as usize)) {
                    Some(true) => sample.view_independent(),
                    _ => sample,
                }
            })
            .collect()
    }
}

type Job = (usize, EyeView, Vec<u32>);

/// A [`PixelTracer`] on its own thread, so that the display never waits for rays: each
/// eye has at most one batch in flight; finished batches are collected without blocking.
pub struct TracerThread {
    /// Whether its samples are gathers ([`PixelTracer::gathers`]).
    gathers: bool,
    jobs: Option<std::sync::mpsc::Sender<Job>>,
    done: std::sync::mpsc::Receiver<(usize, Vec<NewSample>)>,
    in_flight: Vec<bool>,
    handle: Option<std::thread::JoinHandle<()>>,
}

impl TracerThread {
    pub fn spawn(mut source: PixelTracer, eyes: usize) -> TracerThread {
        let gathers = source.gathers();
        let (jobs, job_rx) = std::sync::mpsc::channel::<Job>();
        let (done_tx, done) = std::sync::mpsc::channel();
        let handle = std::thread::Builder::new()
            .name("render-node tracer".into())
            .spawn(move || {
                for (eye, view, pixels) in job_rx {
                    let samples = source.sample(&view, &pixels);
                    if done_tx.send((eye, samples)).is_err() {
                        break;
                    }
                }
            })
            .expect("spawn the tracer thread");
        TracerThread {
            gathers,
            jobs: Some(jobs),
            done,
            in_flight: vec![false; eyes],
            handle: Some(handle),
        }
    }

    /// Whether its samples are gathers over a light field.
    pub fn gathers(&self) -> bool {
        self.gathers
    }

    /// Whether eye `eye` still has a batch being traced.
    pub fn busy(&self, eye: usize) -> bool {
        self.in_flight[eye]
    }

    /// Queues the pixels of one eye (call only when not [`TracerThread::busy`]).
    pub fn submit(&mut self, eye: usize, view: EyeView, pixels: Vec<u32>) {
        if let Some(j) = &self.jobs
            && j.send((eye, view, pixels)).is_ok()
        {
            self.in_flight[eye] = true;
        }
    }

    /// The batches finished so far, without waiting.
    pub fn collect(&mut self) -> Vec<(usize, Vec<NewSample>)> {
        let batches: Vec<_> = self.done.try_iter().collect();
        for (eye, _) in &batches {
            self.in_flight[*eye] = false;
        }
        batches
    }

    /// Waits for every batch in flight.
    pub fn finish(&mut self) -> Vec<(usize, Vec<NewSample>)> {
        let mut out = Vec::new();
        while self.in_flight.iter().any(|&b| b) {
            match self.done.recv() {
                Ok((eye, s)) => {
                    self.in_flight[eye] = false;
                    out.push((eye, s));
                }
                Err(_) => break,
            }
        }
        out
    }
}

impl Drop for TracerThread {
    fn drop(&mut self) {
        self.jobs = None;
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}
