//! The glare figures of a session, frame by frame and eye by eye: a CSV file
//! (`frame,time_ns,eye,ev_lux,dgp,ugr,sources`, one line per eye, `ugr` empty when
//! undefined, `sources` their count) and the session's summary — the fraction of time the
//! higher of the eyes' DGP was above 0.35, 0.40 and 0.45 (the limits of EN 17037's glare
//! classes: imperceptible, perceptible, disturbing, intolerable).

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::error::GlareError;

/// The CSV a session's glare is written to, in its output folder.
pub const GLARE_CSV: &str = "glare.csv";
use crate::figures::Figures;

/// The DGP limits the summary counts time above.
pub const DGP_LIMITS: [f64; 3] = [0.35, 0.40, 0.45];

/// How long DGP was above each of [`DGP_LIMITS`]: each frame's DGP holds from its time to
/// the next frame's, so the last frame's value lasts no time; with all frames at one
/// time (or one frame), the fraction of frames instead.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Summary {
    pub frames: u64,
    pub first_ns: u64,
    last: Option<(u64, f64)>,
    /// Nanoseconds above each limit.
    above_ns: [u64; 3],
    /// Frames above each limit.
    above_frames: [u64; 3],
    pub max_dgp: f64,
}

impl Summary {
    /// Adds a frame shown at `time_ns` (not before the last one) with `dgp`.
    pub fn add(&mut self, time_ns: u64, dgp: f64) {
        match self.last {
            None => self.first_ns = time_ns,
            Some((t, d)) => {
                let dt = time_ns.saturating_sub(t);
                for (k, limit) in DGP_LIMITS.iter().enumerate() {
                    if d > *limit {
                        self.above_ns[k] += dt;
                    }
                }
            }
        }
        for (k, limit) in DGP_LIMITS.iter().enumerate() {
            if dgp > *limit {
                self.above_frames[k] += 1;
            }
        }
        self.last = Some((time_ns.max(self.last.map_or(0, |l| l.0)), dgp));
        self.frames += 1;
        self.max_dgp = self.max_dgp.max(dgp);
    }

    /// Nanoseconds from the first frame to the last.
    pub fn span_ns(&self) -> u64 {
        self.last.map_or(0, |(t, _)| t - self.first_ns)
    }

    /// The fraction of the session DGP was above each of [`DGP_LIMITS`].
    pub fn fractions_above(&self) -> [f64; 3] {
        let span = self.span_ns();
        if span > 0 {
            self.above_ns.map(|a| a as f64 / span as f64)
        } else if self.frames > 0 {
            self.above_frames.map(|a| a as f64 / self.frames as f64)
        } else {
            [0.0; 3]
        }
    }
}

impl std::fmt::Display for Summary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [a, b, c] = self.fractions_above().map(|x| 100.0 * x);
        write!(
            f,
            "{} frames over {:.2} s: DGP above 0.35 for {a:.1}% of the time, above 0.40 for {b:.1}%, above 0.45 for {c:.1}%; highest DGP {:.3}",
            self.frames,
            self.span_ns() as f64 / 1e9,
            self.max_dgp
        )
    }
}

/// The per-frame CSV and its summary.
pub struct GlareLog<W: Write> {
    out: W,
    name: PathBuf,
    summary: Summary,
}

/// The CSV's header line.
pub const HEADER: &str = "frame,time_ns,eye,ev_lux,dgp,ugr,sources";

impl GlareLog<std::io::BufWriter<std::fs::File>> {
    /// A log written to a new file at `path`.
    pub fn create(path: &Path) -> Result<Self, GlareError> {
        let file = std::fs::File::create(path).map_err(|e| GlareError::Write {
            path: path.into(),
            message: e.to_string(),
        })?;
        GlareLog::new(std::io::BufWriter::new(file), path)
    }
}

impl<W: Write> GlareLog<W> {
    /// A log written to `out` (`name` names it in errors); writes the header.
    pub fn new(mut out: W, name: &Path) -> Result<Self, GlareError> {
        writeln!(out, "{HEADER}").map_err(|e| write_error(name, e))?;
        Ok(GlareLog {
            out,
            name: name.into(),
            summary: Summary::default(),
        })
    }

    /// Writes frame `frame`'s figures for each of its eyes (by name), shown at `time_ns`;
    /// the summary counts the frame once, at the higher of its eyes' DGP.
    pub fn record(
        &mut self,
        frame: u64,
        time_ns: u64,
        eyes: &[(&str, &Figures)],
    ) -> Result<(), GlareError> {
        let mut dgp = 0.0f64;
        for (eye, f) in eyes {
            let ugr = f.ugr.map_or(String::new(), |u| format!("{u:.3}"));
            writeln!(
                self.out,
                "{frame},{time_ns},{eye},{:.3},{:.5},{ugr},{}",
                f.ev_lux,
                f.dgp,
                f.sources.len()
            )
            .map_err(|e| write_error(&self.name, e))?;
            dgp = dgp.max(f.dgp);
        }
        if !eyes.is_empty() {
            self.summary.add(time_ns, dgp);
        }
        Ok(())
    }

    pub fn summary(&self) -> &Summary {
        &self.summary
    }

    /// Flushes the file and returns the writer and the summary.
    pub fn finish(mut self) -> Result<(W, Summary), GlareError> {
        self.out.flush().map_err(|e| write_error(&self.name, e))?;
        Ok((self.out, self.summary))
    }
}

fn write_error(name: &Path, e: std::io::Error) -> GlareError {
    GlareError::Write {
        path: name.into(),
        message: e.to_string(),
    }
}
