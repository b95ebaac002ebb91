//! A wall display ([`WallDisplay`]) and one frame of it for all eyes: draw from the cache, choose
//! pixels, have them traced, insert the samples; and the files a headless node writes.

use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::{Quat, Vec3};
use holocave_protocol::cluster::WireObject;
use holocave_scene::{ObjectPaths, Placement, Scene};
use holocave_tracer::film::Image;

use crate::cache::{RenderCache, StepTimes};
use crate::feed::holodeck::{HolodeckCounts, HolodeckSource};
use crate::feed::tracer::{PixelTracer, TracerThread};
use crate::light_field::FrameWork;
use crate::light_field::prior;
use crate::{EyeView, RenderNodeError, VlfBase};

/// What one frame did.
#[derive(Clone, Debug, Default)]
pub struct FrameReport {
    /// Pixels chosen per eye.
    pub chosen: Vec<usize>,
    /// Drawing from the cache and choosing pixels (GPU work + read-back).
    pub draw: Duration,
    /// Tracing the chosen pixels (zero when traced on the tracer thread).
    pub trace: Duration,
    /// Samples inserted this frame.
    pub inserted: usize,
    /// Uploading and inserting the samples.
    pub insert: Duration,
    /// Per-step times (only when timed).
    pub steps: StepTimes,
    /// The light field's visibility: one ray cast per pixel of every eye (zero without one).
    pub vlf: Duration,
    /// What the light field's per-pixel pass did, over every eye.
    pub vlf_work: FrameWork,
}

/// Where a wall display gets its samples (its live feed).
pub enum SampleFeed {
    /// Traced between frames, on the display's thread (deterministic).
    Inline(PixelTracer),
    /// Traced on a thread of its own: frames never wait for rays.
    Thread(TracerThread),
    /// Asked of a holodeck server (in this process or over TCP): frames hand over their
    /// chosen pixels and insert whatever samples have arrived, never waiting.
    Holodeck(HolodeckSource),
}

/// The render cache and its sample source.
pub struct WallDisplay {
    pub cache: RenderCache,
    pub feed: SampleFeed,
    /// Samples asked for per eye and frame.
    pub samples_per_eye: u32,
    exposure: Option<f32>,
    vlf: Option<Arc<VlfBase>>,
    /// Samples made as the feed makes them, to measure the light field's worth at the
    /// first frame drawn ([`crate::light_field::prior`]); `None` once measured, or when given.
    measurer: Option<PixelTracer>,
    /// What the light field is worth in samples per pixel now.
    prior: f32,
    /// The views of the last frame drawn, per eye (each pixel's direction from the eye,
    /// for the human-vision tone mapping).
    pub views: Vec<EyeView>,
}

impl WallDisplay {
    /// True when the samples' source is a holodeck server that is no longer reachable
    /// (the cache still draws; no new samples arrive).
    pub fn source_lost(&self) -> bool {
        matches!(&self.feed, SampleFeed::Holodeck(h) if !h.is_connected())
    }

    /// What a holodeck feed has received and used so far (`None`: another feed).
    pub fn holodeck_counts(&self) -> Option<HolodeckCounts> {
        match &self.feed {
            SampleFeed::Holodeck(h) => Some(h.counts()),
            _ => None,
        }
    }

    /// Traces between frames (synchronous, deterministic).
    pub fn new(cache: RenderCache, source: PixelTracer, samples_per_eye: u32) -> Self {
        WallDisplay {
            cache,
            feed: SampleFeed::Inline(source),
            samples_per_eye,
            exposure: None,
            vlf: None,
            measurer: None,
            prior: 0.0,
            views: Vec::new(),
        }
    }

    /// Traces on a thread of its own; each eye has at most one batch in flight, and a
    /// frame inserts whatever has arrived.
    pub fn threaded(cache: RenderCache, source: PixelTracer, samples_per_eye: u32) -> Self {
        let eyes = cache.eye_count();
        WallDisplay {
            cache,
            feed: SampleFeed::Thread(TracerThread::spawn(source, eyes)),
            samples_per_eye,
            exposure: None,
            vlf: None,
            measurer: None,
            prior: 0.0,
            views: Vec::new(),
        }
    }

    /// Draws from a holodeck server's samples (see [`HolodeckSource`]).
    pub fn holodeck(cache: RenderCache, source: HolodeckSource, samples_per_eye: u32) -> Self {
        WallDisplay {
            cache,
            feed: SampleFeed::Holodeck(source),
            samples_per_eye,
            exposure: None,
            vlf: None,
            measurer: None,
            prior: 0.0,
            views: Vec::new(),
        }
    }

    /// Draws the light field `base` under the samples from now on, worth `prior` samples
    /// per pixel (see `cache/shade_field.wgsl`).
    pub fn with_vlf(mut self, base: Arc<VlfBase>, prior: f32) -> Result<Self, RenderNodeError> {
        self.cache.set_vlf(base.values(), prior)?;
        self.prior = prior;
        if self.gathers() {
            base.keep_gathers(prior);
        }
        self.vlf = Some(base);
        Ok(self)
    }

    /// Whether the feed's samples are gathers over the light field (kept in its
    /// elements as well: [`VlfBase::keep_gathers`]).
    fn gathers(&self) -> bool {
        match &self.feed {
            SampleFeed::Inline(t) => t.gathers(),
            SampleFeed::Thread(t) => t.gathers(),
            SampleFeed::Holodeck(_) => false,
        }
    }

    /// Measures the light field's worth at the first frame drawn ([`crate::light_field::prior`]), with
    /// samples `measurer` makes as the feed makes its own.
    pub fn measuring_prior(mut self, measurer: PixelTracer) -> Self {
        self.measurer = Some(measurer);
        self
    }

    /// What the light field is worth in samples per pixel now (0 without one).
    pub fn prior(&self) -> f32 {
        self.prior
    }

    /// Measures the light field's worth on `view` when it is still to be measured.
    fn measure_prior(&mut self, view: &EyeView) {
        let (Some(base), Some(m)) = (&self.vlf, self.measurer.take()) else {
            return;
        };
        let found = prior::measure(
            view,
            |rays, estimates| base.field_radiance(rays, estimates),
            |rays, seed| m.radiance(rays, seed),
        );
        tracing::info!(
            "{} samples: {found}",
            if m.gathers() { "gather" } else { "path" }
        );
        self.prior = found.samples;
        // Per pixel only under full paths, whose mean is the true radiance (see
        // `crate::light_field::prior`): a gather's mean has the field's error one bounce later.
        let spread = if m.gathers() { 0.0 } else { found.spread };
        self.cache.set_vlf_prior(self.prior, spread);
        base.under_samples(found);
        if self.gathers() {
            base.keep_gathers(self.prior);
        }
    }

    /// Puts the scene's moving objects where a frame state says (by name; an object the
    /// state does not name, or names with a broken placement, stays where it was). Drawn
    /// over the light field only: without one there is nothing to do.
    pub fn place_objects(&mut self, objects: &[WireObject]) {
        let Some(base) = &self.vlf else { return };
        if base.scene().objects().is_empty() {
            return;
        }
        let placements = placements_of(base.scene(), base.placements(), objects);
        self.place(&placements);
    }

    /// Puts the scene's moving objects where `paths` has them at `t` seconds.
    pub fn place_objects_on_paths(&mut self, paths: &ObjectPaths, t: f64) {
        if let Some(base) = &self.vlf {
            let placements = paths.placements_at(base.scene(), t);
            self.place(&placements);
        }
    }

    /// Puts the objects at `placements`; the cache's points on them move along, and those
    /// in their shadows, old and new, are dropped.
    fn place(&mut self, placements: &[Placement]) {
        let Some(base) = &self.vlf else { return };
        let moves = base.place_objects(placements);
        self.cache.move_objects(&moves, base.shadow_lights());
    }

    /// One frame: draw every eye and choose its pixels; inline, trace and insert them (the
    /// samples appear in the next frame); threaded, insert the batches that have arrived
    /// and send this frame's pixels for every eye whose last batch is back; from a
    /// holodeck, insert the samples that have arrived and send this frame's pixels.
    pub fn frame(&mut self, views: &[EyeView], timed: bool) -> FrameReport {
        let mut report = FrameReport::default();
        self.views = views.to_vec();
        let start = Instant::now();
        let arrived = match &mut self.feed {
            SampleFeed::Inline(_) => Vec::new(),
            SampleFeed::Thread(t) => t.collect(),
            SampleFeed::Holodeck(h) => h.collect(),
        };
        for (eye, samples) in arrived {
            if eye < self.cache.eye_count() {
                report.inserted += samples.len();
                self.cache.insert(eye, &samples);
            }
        }
        report.insert += start.elapsed();
        if let Some(view) = views.first() {
            self.measure_prior(view);
        }
        if let Some(base) = &self.vlf {
            let t = Instant::now();
            base.with_kept_values(|values, changed| self.cache.update_vlf_values(values, changed));
            for (eye, view) in views.iter().enumerate() {
                base.draw_lookups(eye, view, &mut self.cache);
            }
            report.vlf = t.elapsed();
            report.vlf_work = base.take_work();
        }
        let t = Instant::now();
        let targets = vec![self.samples_per_eye; views.len()];
        let chosen = self.cache.draw(views, &targets, timed, &mut report.steps);
        report.draw = t.elapsed();
        if let SampleFeed::Holodeck(h) = &mut self.feed {
            report.chosen = chosen.iter().map(Vec::len).collect();
            h.submit(views, chosen);
            return report;
        }
        for (eye, (view, pixels)) in views.iter().zip(chosen).enumerate() {
            report.chosen.push(pixels.len());
            match &mut self.feed {
                SampleFeed::Inline(source) => {
                    let t = Instant::now();
                    let samples = source.sample(view, &pixels);
                    report.trace += t.elapsed();
                    let t = Instant::now();
                    report.inserted += samples.len();
                    self.cache.insert(eye, &samples);
                    report.insert += t.elapsed();
                }
                SampleFeed::Thread(thread) => {
                    if !thread.busy(eye) {
                        thread.submit(eye, *view, pixels);
                    }
                }
                SampleFeed::Holodeck(_) => unreachable!("handled above"),
            }
        }
        report
    }

    /// The exposure for PNG previews ([`Image::lit_exposure`]), set from the first image
    /// with any lit pixel, then held steady unless it changes by more than a factor of two
    /// (so the previews do not pump).
    pub fn exposure(&mut self, image: &Image) -> f32 {
        let Some(now) = image.lit_exposure() else {
            return self.exposure.unwrap_or(1.0);
        };
        match self.exposure {
            Some(e) if (now / e) < 2.0 && (e / now) < 2.0 => e,
            _ => {
                self.exposure = Some(now);
                now
            }
        }
    }
}

/// The placements `now` with each object a frame state names moved where it says; an
/// unknown name, or a placement that is not a finite rigid motion, is refused with a
/// warning and leaves that object where it was (a frame state is checked, never trusted).
fn placements_of(scene: &Scene, mut now: Vec<Placement>, objects: &[WireObject]) -> Vec<Placement> {
    for o in objects {
        let p = Placement::new(
            Vec3::from_array(o.position),
            Quat::from_array(o.orientation),
        );
        let rigid = p.translation.is_finite()
            && p.rotation.is_finite()
            && (p.rotation.length() - 1.0).abs() < 1e-3;
        match scene.object_index(&o.name) {
            Some(k) if rigid => now[k] = Placement::new(p.translation, p.rotation.normalize()),
            Some(_) => tracing::warn!("object {:?}: placement {p:?} is not rigid; ignored", o.name),
            None => tracing::warn!("object {:?} is not a moving object of this scene", o.name),
        }
    }
    now
}

/// Tiles previews into one picture for looking at: one row per entry of `rows`, each image
/// scaled up `zoom` times (nearest neighbour), 4-pixel grey gutters.
pub fn contact_sheet(rows: &[Vec<image::RgbImage>], zoom: u32) -> image::RgbImage {
    let zoom = zoom.max(1);
    let gap = 4;
    let cell_w = rows.iter().flatten().map(|i| i.width()).max().unwrap_or(1) * zoom;
    let cell_h = rows.iter().flatten().map(|i| i.height()).max().unwrap_or(1) * zoom;
    let cols = rows.iter().map(Vec::len).max().unwrap_or(1) as u32;
    let mut sheet = image::RgbImage::from_pixel(
        cols * (cell_w + gap) + gap,
        rows.len() as u32 * (cell_h + gap) + gap,
        image::Rgb([96, 96, 96]),
    );
    for (r, row) in rows.iter().enumerate() {
        for (c, img) in row.iter().enumerate() {
            let (x0, y0) = (
                gap + c as u32 * (cell_w + gap),
                gap + r as u32 * (cell_h + gap),
            );
            for y in 0..img.height() * zoom {
                for x in 0..img.width() * zoom {
                    sheet.put_pixel(x0 + x, y0 + y, *img.get_pixel(x / zoom, y / zoom));
                }
            }
        }
    }
    sheet
}

#[cfg(test)]
mod tests {
    use super::*;
    use holocave_scene::LoadOptions;

    /// A frame state's placements are taken by name; a NaN, a scaled rotation and an
    /// unknown name are refused and leave the objects where they were.
    #[test]
    fn a_frame_states_placements_are_checked() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/room.gltf");
        let opts = LoadOptions::with_objects(&["block"]);
        let scene = Scene::load(&path, &opts).unwrap();
        let rest = scene.rest_placements();
        let wire = |name: &str, position: [f32; 3], orientation: [f32; 4]| WireObject {
            name: name.into(),
            position,
            orientation,
        };
        let turned = Quat::from_rotation_y(0.5);
        let moved = placements_of(
            &scene,
            rest.clone(),
            &[wire("block", [1.0, 0.0, -1.0], turned.to_array())],
        );
        assert_eq!(
            moved[0],
            Placement::new(Vec3::new(1.0, 0.0, -1.0), turned.normalize())
        );
        for bad in [
            wire("block", [f32::NAN, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]),
            wire("block", [0.0; 3], [0.0, 0.0, 0.0, 2.0]),
            wire("block", [0.0; 3], [f32::INFINITY, 0.0, 0.0, 1.0]),
            wire("sofa", [0.0; 3], [0.0, 0.0, 0.0, 1.0]),
        ] {
            assert_eq!(
                placements_of(&scene, moved.clone(), std::slice::from_ref(&bad)),
                moved,
                "{bad:?}"
            );
        }
    }
}
