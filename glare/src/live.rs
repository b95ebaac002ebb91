//! Glare measured while a session runs: the master offers each frame's views as it makes
//! the frame, and a thread of its own measures the newest views it has not measured
//! whenever it is free (frames offered while it measures are skipped, so the session never
//! waits for it), writes each measured frame's figures to the CSV ([`GlareLog`]) and keeps
//! the latest for a status line. A measurement takes longer than a frame on a CPU (the
//! breakfast room's 64² fisheye, 0.4 s on two shared cores), so live figures come every few
//! frames; `sim --glare` measures every frame after the run instead
//! ([`crate::session::measure_session`]).

use std::path::Path;
use std::sync::{Arc, Condvar, Mutex, PoisonError};
use std::thread::JoinHandle;

use crate::error::GlareError;
use crate::log::{GlareLog, Summary};
use crate::meter::GlareMeter;
use crate::session::FrameView;

/// The views waiting to be measured, the latest figures, and whether to stop.
#[derive(Default)]
struct Shared {
    pending: Option<Vec<FrameView>>,
    /// The last frame measured and the higher of its eyes' DGP.
    latest: Option<(u64, f64)>,
    done: bool,
}

/// A session's glare, measured on a thread beside it.
pub struct LiveGlare {
    shared: Arc<(Mutex<Shared>, Condvar)>,
    thread: Option<JoinHandle<Result<Summary, GlareError>>>,
}

impl LiveGlare {
    /// [`Self::start`] into `dir`'s [`crate::log::GLARE_CSV`], the folder made if missing.
    pub fn start_in(meter: GlareMeter, dir: &Path) -> Result<LiveGlare, GlareError> {
        std::fs::create_dir_all(dir).map_err(|e| GlareError::Write {
            path: dir.to_path_buf(),
            message: e.to_string(),
        })?;
        Self::start(meter, &dir.join(crate::log::GLARE_CSV))
    }

    /// Starts measuring with `meter` into a new CSV at `csv`.
    pub fn start(meter: GlareMeter, csv: &Path) -> Result<LiveGlare, GlareError> {
        let mut log = GlareLog::create(csv)?;
        let shared = Arc::new((Mutex::new(Shared::default()), Condvar::new()));
        let worker = shared.clone();
        let thread = std::thread::spawn(move || {
            let (lock, wake) = &*worker;
            loop {
                let views = {
                    let mut s = lock.lock().unwrap_or_else(PoisonError::into_inner);
                    while s.pending.is_none() && !s.done {
                        s = wake.wait(s).unwrap_or_else(PoisonError::into_inner);
                    }
                    match s.pending.take() {
                        Some(v) => v,
                        None => break,
                    }
                };
                let Some(first) = views.first() else { continue };
                let figures = views
                    .iter()
                    .map(|v| meter.measure(v.eye, v.look))
                    .collect::<Result<Vec<_>, _>>()?;
                let eyes: Vec<(&str, &_)> =
                    views.iter().map(|v| v.eye_name).zip(&figures).collect();
                log.record(first.frame, first.time_ns, &eyes)?;
                let dgp = figures.iter().map(|f| f.dgp).fold(0.0, f64::max);
                lock.lock().unwrap_or_else(PoisonError::into_inner).latest =
                    Some((first.frame, dgp));
            }
            Ok(log.finish()?.1)
        });
        Ok(LiveGlare {
            shared,
            thread: Some(thread),
        })
    }

    /// Offers one frame's views (one per eye): measured next unless newer ones come first.
    pub fn offer(&self, views: Vec<FrameView>) {
        let (lock, wake) = &*self.shared;
        lock.lock().unwrap_or_else(PoisonError::into_inner).pending = Some(views);
        wake.notify_one();
    }

    /// The last frame measured and the higher of its eyes' DGP.
    pub fn latest(&self) -> Option<(u64, f64)> {
        let (lock, _) = &*self.shared;
        lock.lock().unwrap_or_else(PoisonError::into_inner).latest
    }

    /// Measures the views still pending, stops, and returns the summary of the frames
    /// measured.
    pub fn finish(mut self) -> Result<Summary, GlareError> {
        self.stop()
    }

    fn stop(&mut self) -> Result<Summary, GlareError> {
        let (lock, wake) = &*self.shared;
        lock.lock().unwrap_or_else(PoisonError::into_inner).done = true;
        wake.notify_one();
        match self.thread.take() {
            Some(t) => t.join().unwrap_or_else(|_| {
                Err(GlareError::Write {
                    path: "glare.csv".into(),
                    message: "the glare thread panicked".into(),
                })
            }),
            None => Ok(Summary::default()),
        }
    }
}

impl Drop for LiveGlare {
    fn drop(&mut self) {
        let _ = self.stop();
    }
}
