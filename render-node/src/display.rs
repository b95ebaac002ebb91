//! One frame of the display process for all eyes of a wall: draw from the cache, choose
//! pixels, have them traced, insert the samples; and the files a headless node writes.

use std::path::Path;
use std::time::{Duration, Instant};

use holocave_tracer::film::Image;

use crate::cache::{RenderCache, StepTimes};
use crate::source::TracerSource;
use crate::{EyeView, RenderNodeError};

/// What one frame did.
#[derive(Clone, Debug, Default)]
pub struct FrameReport {
    /// Pixels chosen per eye.
    pub chosen: Vec<usize>,
    /// Drawing from the cache and choosing pixels (GPU work + read-back).
    pub draw: Duration,
    /// Tracing the chosen pixels.
    pub trace: Duration,
    /// Uploading and inserting the samples.
    pub insert: Duration,
    /// Per-step times (only when timed).
    pub steps: StepTimes,
}

/// The render cache and its sample source.
pub struct DisplayProcess {
    pub cache: RenderCache,
    pub source: TracerSource,
    /// Samples asked for per eye and frame.
    pub samples_per_eye: u32,
    exposure: Option<f32>,
}

impl DisplayProcess {
    pub fn new(cache: RenderCache, source: TracerSource, samples_per_eye: u32) -> Self {
        DisplayProcess {
            cache,
            source,
            samples_per_eye,
            exposure: None,
        }
    }

    /// One frame: draw every eye, then trace and insert what each eye chose (the samples
    /// appear in the next frame). Synchronous: the tracer runs between frames.
    pub fn frame(&mut self, views: &[EyeView], timed: bool) -> FrameReport {
        let mut report = FrameReport::default();
        let t = Instant::now();
        let targets = vec![self.samples_per_eye; views.len()];
        let chosen = self.cache.draw(views, &targets, timed, &mut report.steps);
        report.draw = t.elapsed();
        for (eye, (view, pixels)) in views.iter().zip(&chosen).enumerate() {
            let t = Instant::now();
            let samples = self.source.sample(view, pixels);
            report.trace += t.elapsed();
            let t = Instant::now();
            self.cache.insert(eye, &samples);
            report.insert += t.elapsed();
            report.chosen.push(pixels.len());
        }
        report
    }

    /// The exposure for PNG previews: set from the first image, then held steady unless
    /// the scene's log-average brightness changes by more than a factor of two (so the
    /// previews do not pump).
    pub fn exposure(&mut self, image: &Image) -> f32 {
        let now = image.auto_exposure();
        match self.exposure {
            Some(e) if (now / e) < 2.0 && (e / now) < 2.0 => e,
            _ => {
                self.exposure = Some(now);
                now
            }
        }
    }
}

/// Writes `image` as `<stem>.exr` (linear) and `<stem>.png` (preview at `exposure`).
pub fn write_image(dir: &Path, stem: &str, image: &Image, exposure: f32) -> Result<(), RenderNodeError> {
    std::fs::create_dir_all(dir).map_err(|e| RenderNodeError::Write {
        path: dir.display().to_string(),
        message: e.to_string(),
    })?;
    let err = |e: holocave_tracer::film::FilmError| RenderNodeError::Write {
        path: dir.join(stem).display().to_string(),
        message: e.to_string(),
    };
    image.write_exr(&dir.join(format!("{stem}.exr"))).map_err(err)?;
    image
        .write_png(&dir.join(format!("{stem}.png")), exposure)
        .map_err(err)
}
