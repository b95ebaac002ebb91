//! A session's glare, frame by frame: each frame's view (the head's eye and gaze in scene
//! coordinates, as the frame state placed it) measured by one [`GlareMeter`], the figures
//! written in frame order to a CSV ([`GlareLog`]) and summed up. The frames are measured
//! in parallel after the session, so measuring changes nothing a wall shows.

use std::path::Path;

use glam::Vec3;
use rayon::prelude::*;

use crate::error::GlareError;
use crate::log::{GlareLog, Summary};
use crate::meter::GlareMeter;

/// What the viewer saw at one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameView {
    pub frame: u64,
    /// When the frame was shown (ns on the session's clock).
    pub time_ns: u64,
    /// Between the eyes, scene coordinates.
    pub eye: Vec3,
    /// The gaze: the head's forward direction, scene coordinates.
    pub look: Vec3,
}

/// Measures every view with `meter` and writes the figures to `csv`; the session's summary.
pub fn measure_session(
    meter: &GlareMeter,
    views: &[FrameView],
    csv: &Path,
) -> Result<Summary, GlareError> {
    let figures: Vec<_> = views
        .par_iter()
        .map(|v| meter.measure(v.eye, v.look))
        .collect::<Result<_, _>>()?;
    let mut log = GlareLog::create(csv)?;
    for (v, f) in views.iter().zip(&figures) {
        log.record(v.frame, v.time_ns, f)?;
    }
    Ok(log.finish()?.1)
}
