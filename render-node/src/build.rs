//! The one builder of a wall's display: the render cache on a GPU device, the feed its
//! samples come from (the path tracer inline or on a thread, or a holodeck server), and the
//! light field drawn under them. `node --standalone`, the cluster node and `compare` all
//! make their displays here.

use std::sync::Arc;

use holocave_cave::Size;
use holocave_tracer::Tracer;

use crate::light_field::DEFAULT_PRIOR_SAMPLES;

use crate::{
    Gpu, HolodeckSource, PixelTracer, Prior, RenderCache, RenderNodeError, VlfBase, WallDisplay,
};

/// Where a display's samples come from.
pub enum Feed {
    /// The path tracer, between frames on the display's thread (deterministic).
    Inline,
    /// The path tracer on a thread of its own: frames never wait for rays.
    Thread,
    /// A holodeck server's display service (in this process or over TCP).
    Holodeck(HolodeckSource),
}

/// A baked light field drawn under a display's samples.
#[derive(Clone)]
pub struct LightField {
    pub base: Arc<VlfBase>,
    /// How many samples the light field is worth in a pixel.
    pub prior: Prior,
}

/// What every display of a wall shares, whatever feeds it.
#[derive(Clone)]
pub struct DisplayBuilder {
    /// Pixels per eye.
    pub size: Size,
    pub eyes: usize,
    /// Samples asked for per eye and frame.
    pub samples: u32,
    /// The tracer of the inline and threaded feeds.
    pub tracer: Arc<Tracer>,
    /// The tracer's random stream (walls of one cluster take different ones).
    pub seed: u64,
    /// Paths averaged into each traced sample.
    pub paths: u32,
    /// The device to draw on (a window's); `None`: a new one per display.
    pub gpu: Option<Gpu>,
    pub light_field: Option<LightField>,
    /// With a light field, the tracer's samples are gathers over it (exact direct light
    /// at the point seen and after one bounce, the field beyond: [`PixelTracer::with_gather`])
    /// instead of full paths.
    pub gather: bool,
}

impl DisplayBuilder {
    /// Displays of `eyes` eyes at `size` pixels asking for `samples` per eye and frame, one
    /// path per sample, seed 1, no light field, on a new device.
    pub fn new(size: Size, eyes: usize, samples: u32, tracer: Arc<Tracer>) -> Self {
        DisplayBuilder {
            size,
            eyes,
            samples,
            tracer,
            seed: 1,
            paths: 1,
            gpu: None,
            light_field: None,
            gather: false,
        }
    }

    /// The render cache alone, on the builder's device.
    pub fn cache(&self) -> Result<RenderCache, RenderNodeError> {
        let gpu = match &self.gpu {
            Some(g) => g.clone(),
            None => Gpu::new()?,
        };
        Ok(RenderCache::for_wall(
            gpu,
            self.size,
            self.eyes,
            self.samples,
        ))
    }

    /// A display fed by `feed`, with the light field under it when there is one.
    pub fn build(&self, feed: Feed) -> Result<WallDisplay, RenderNodeError> {
        let cache = self.cache()?;
        // The tracer feeds' samples, and a second stream of the same kind to measure the
        // light field's worth with (a holodeck's samples are full paths).
        let gathers = match (&self.light_field, &feed) {
            (Some(lf), Feed::Inline | Feed::Thread) if self.gather => Some(lf.base.clone()),
            _ => None,
        };
        let tracer = |seed: u64| {
            let t = PixelTracer::new(self.tracer.clone(), seed).with_paths(self.paths);
            match &gathers {
                Some(base) => t.with_gather(base.clone()),
                None => t,
            }
        };
        let display = match feed {
            Feed::Inline => WallDisplay::new(cache, tracer(self.seed), self.samples),
            Feed::Thread => WallDisplay::threaded(cache, tracer(self.seed), self.samples),
            Feed::Holodeck(source) => WallDisplay::holodeck(cache, source, self.samples),
        };
        let Some(lf) = &self.light_field else {
            return Ok(display);
        };
        Ok(match lf.prior {
            Prior::Samples(k) => display.with_vlf(lf.base.clone(), k)?,
            Prior::Measured => display
                .with_vlf(lf.base.clone(), DEFAULT_PRIOR_SAMPLES)?
                .measuring_prior(tracer(!self.seed)),
        })
    }
}
