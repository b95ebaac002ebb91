//! A wall shown in its windows, frame by frame: the tone curve kept current from the first
//! eye's histogram (made on the GPU, so the frame never leaves it), every window prepared
//! (drawn, waited for) before the node says Ready and shown on the master's Swap, and each
//! present's time logged; and the skew between walls, read back from those logs.

use std::collections::{BTreeMap, BTreeSet};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use glam::Vec3;
use holocave_cave::{Eye, Size, Wall};
use holocave_protocol::cluster::{DeskInput, FrameState, VeilSource as WireVeil};

use crate::node::follow::Presentation;
use crate::present::tonemap::wall_directions;
use crate::present::vision::gpu::VisionPass;
use crate::present::vision::{Fovea, VeilSource, VeilSources};
use crate::present::window::{Screens, WindowError};
use crate::present::{Histogrammer, Prepared, layout_eyes};
use crate::{ToneMapper, ToneMode, WallDisplay};

/// A cluster node's windows: each frame prepared before Ready, shown on Swap (then `then`
/// runs, e.g. the presented log), abandoned when a newer state comes first.
pub struct ClusterWindows<'a, F> {
    pub output: WindowOutput<'a>,
    pub then: F,
}

impl<F> Presentation for ClusterWindows<'_, F>
where
    F: FnMut(&FrameState, &mut WallDisplay) -> Result<(), String>,
{
    fn prepare(&mut self, _: &FrameState, display: &mut WallDisplay) {
        self.output.prepare(display);
    }

    fn show(&mut self, state: &FrameState, display: &mut WallDisplay) -> Result<(), String> {
        if self.output.show(state.frame)? {
            (self.then)(state, display)?;
        }
        Ok(())
    }

    fn abandon(&mut self, _: &FrameState) {
        self.output.abandon();
    }

    fn closed(&self) -> Option<String> {
        self.output
            .screens
            .closed()
            .then(|| "its window was closed".to_owned())
    }

    fn desk_inputs(&mut self) -> Vec<DeskInput> {
        self.output.screens.desk.take()
    }

    fn import_veil(&mut self, wall: &str, sources: &[WireVeil]) {
        let sources = sources
            .iter()
            .map(|s| VeilSource {
                dir: Vec3::from(s.dir),
                flux: Vec3::from(s.flux),
            })
            .collect();
        self.output.import(wall, VeilSources(sources));
    }

    fn export_veil(&mut self, display: &WallDisplay) -> Option<Vec<WireVeil>> {
        let found = self.output.sources(display.cache.gpu())?;
        Some(
            (found.0.iter())
                .map(|s| WireVeil {
                    dir: s.dir.to_array(),
                    flux: s.flux.to_array(),
                })
                .collect(),
        )
    }
}

/// A wall shown in windows: the tone mapping and each window's eyes.
pub struct WindowOutput<'a> {
    pub screens: &'a mut Screens,
    eyes: Vec<[usize; 2]>,
    tone: ToneMapper,
    log: Option<(std::fs::File, String)>,
    /// Frames shown in every window that was ready.
    pub shown: u64,
    /// Time spent keeping the tone mapping current (the histogram), and how often.
    tone_time: Duration,
    tone_updates: u64,
    histogrammer: Histogrammer,
    /// Human mode: each eye's image as a person would see it, made on the GPU.
    vision: Vec<VisionPass>,
    /// Human mode: the other walls' bright sources, veiling this wall too (each wall's
    /// newest, and all of them merged).
    by_wall: BTreeMap<String, VeilSources>,
    pub imported: VeilSources,
    /// Human mode: the first eye's foveal grid in the frame last prepared (its bright
    /// sources are read back only when shared: [`Self::sources`]).
    fovea: Option<Fovea>,
}

impl<'a> WindowOutput<'a> {
    /// The windows of `wall` in `screens`, tone-mapped by `tone`, each present's time
    /// appended to the file `log` ("FRAME NS" lines) if given.
    pub fn new(
        screens: &'a mut Screens,
        wall: &Wall,
        tone: ToneMapper,
        log: Option<&Path>,
    ) -> Result<WindowOutput<'a>, WindowError> {
        let eyes = screens
            .presenters
            .iter()
            .map(|p| layout_eyes(&p.settings, Eye::for_mode(wall.stereo)))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| WindowError::Layout(format!("wall {:?}: {e}", wall.name)))?;
        let log = log
            .map(|p| {
                let f = std::fs::OpenOptions::new()
                    .create(true)
                    .append(true)
                    .open(p)
                    .map_err(|e| WindowError::PresentLog {
                        path: p.display().to_string(),
                        message: e.to_string(),
                    })?;
                Ok::<_, WindowError>((f, p.display().to_string()))
            })
            .transpose()?;
        Ok(WindowOutput {
            histogrammer: Histogrammer::new(&screens.gpu),
            screens,
            eyes,
            tone,
            log,
            shown: 0,
            tone_time: Duration::ZERO,
            tone_updates: 0,
            vision: Vec::new(),
            by_wall: BTreeMap::new(),
            imported: VeilSources::none(),
            fovea: None,
        })
    }

    /// Human mode: the bright sources of the first eye in the frame last prepared, which
    /// veil the other walls (read back from the GPU here, once, for whoever shares them).
    pub fn sources(&mut self, gpu: &crate::Gpu) -> Option<VeilSources> {
        let fovea = self.fovea.take()?;
        Some(self.vision.first()?.sources(gpu, &fovea))
    }

    /// Takes wall `wall`'s newest veiling sources (human mode): this wall is veiled by
    /// them from the next frame on.
    pub fn import(&mut self, wall: &str, sources: VeilSources) {
        self.by_wall.insert(wall.to_owned(), sources);
        self.imported = VeilSources::merged(self.by_wall.values());
    }

    /// Draws the display's images into every window and waits for the GPU (before Ready);
    /// how many windows have a frame ready.
    pub fn prepare(&mut self, display: &WallDisplay) -> usize {
        // The histogram of the first eye's image, as the headless previews take it.
        let t = Instant::now();
        let gpu = display.cache.gpu();
        let eye_count = display.cache.eye_count();
        // Human mode: every eye seen as a person would see it, on the GPU, from the views
        // of the frame drawn (their pixels' directions give the foveal grid).
        let human = self.tone.mode == ToneMode::Human && display.views.len() == eye_count;
        if human {
            while self.vision.len() < eye_count {
                self.vision.push(VisionPass::new(gpu));
            }
            for (eye, view) in display.views.iter().enumerate() {
                let Size {
                    width: w,
                    height: h,
                } = display.cache.eye_size(eye);
                let fovea = Fovea::new(w, h, &wall_directions(&view.wall));
                self.vision[eye].run(
                    gpu,
                    display.cache.color_buffer(eye),
                    &fovea,
                    &self.imported,
                    self.tone.efficacy,
                );
                if eye == 0 {
                    self.fovea = Some(fovea);
                }
            }
        }
        let buffer = |eye: usize| {
            if human {
                &self.vision[eye].seen
            } else {
                display.cache.color_buffer(eye)
            }
        };
        // The histogram made on the GPU: the frame itself is never read back.
        let Size {
            width: w,
            height: h,
        } = display.cache.eye_size(0);
        let hist = self
            .histogrammer
            .histogram(gpu, buffer(0), w * h, self.tone.efficacy);
        self.tone.update_from(hist.as_ref(), false);
        self.tone_time += t.elapsed();
        self.tone_updates += 1;
        let curve = self.tone.curve();
        let mut ready = 0;
        for (p, eyes) in self.screens.presenters.iter_mut().zip(&self.eyes) {
            let bufs = [buffer(eyes[0]), buffer(eyes[1])];
            let size = display.cache.eye_size(eyes[0]);
            if p.prepare(bufs, size, curve.as_ref()) == Prepared::Ready {
                ready += 1;
            }
        }
        ready
    }

    /// Presents every prepared window (on Swap) and logs `frame`'s present time; true when
    /// some window showed it.
    pub fn show(&mut self, frame: u64) -> Result<bool, String> {
        let mut any = false;
        for p in &mut self.screens.presenters {
            any |= p.show();
        }
        if any {
            self.shown += 1;
            if let Some((f, path)) = &mut self.log {
                let ns = SystemTime::now()
                    .duration_since(UNIX_EPOCH)
                    .map_or(0, |d| d.as_nanos());
                writeln!(f, "{frame} {ns}").map_err(|e| format!("{path}: {e}"))?;
            }
        }
        Ok(any)
    }

    /// Drops every prepared, unshown frame (a newer frame state came first).
    pub fn abandon(&mut self) {
        for p in &mut self.screens.presenters {
            p.abandon();
        }
    }

    /// Keeps the last frame on screen for `seconds` (redrawn at `fps`, so a resized or
    /// uncovered window shows it again), or until a window is closed.
    pub fn linger(&mut self, display: &WallDisplay, seconds: f64, fps: f64, frame: u64) {
        let end = Instant::now() + Duration::from_secs_f64(seconds.max(0.0));
        let period = Duration::from_secs_f64(1.0 / fps.clamp(1.0, 240.0));
        while Instant::now() < end && !self.screens.closed() {
            let t = Instant::now();
            self.prepare(display);
            let _ = self.show(frame);
            if let Some(rest) = period.checked_sub(t.elapsed()) {
                std::thread::sleep(rest.min(end.saturating_duration_since(Instant::now())));
            }
        }
    }

    /// The windows' end: with `linger` seconds, the last of `frames` kept on screen that
    /// long (redrawn at `fps`) unless a window was closed, said first on stdout (tests wait
    /// for that line before taking a screenshot); then their summary.
    pub fn finish(&mut self, display: &WallDisplay, (linger, fps): (f64, f64), frames: u64) {
        let last = frames.saturating_sub(1);
        if linger > 0.0 && !self.screens.closed() {
            println!("lingering: frame {last} on screen for {linger} s");
            let _ = std::io::stdout().flush();
            self.linger(display, linger, fps, last);
        }
        print!("{}", self.summary());
    }

    /// Per-frame costs of presenting, for the summary line.
    pub fn summary(&self) -> String {
        let mut s = format!(
            "tone mapping kept current (the first eye's histogram, made on the GPU): {:.2} ms per frame\n",
            self.tone_time.as_secs_f64() * 1e3 / self.tone_updates.max(1) as f64
        );
        for (k, p) in self.screens.presenters.iter().enumerate() {
            let t = &p.times;
            let n = t.prepared.max(1) as f64;
            let ms = |d: Duration| d.as_secs_f64() * 1e3 / n;
            s += &format!(
                "window {k} ({}, {}): {} frames drawn, {} shown, {} skipped, {} abandoned; per frame: acquire {:.2} ms, draw + wait {:.2} ms, present {:.2} ms\n",
                p.surface_size(),
                p.settings.layout.name(),
                t.prepared,
                t.shown,
                t.skipped,
                t.abandoned,
                ms(t.acquire),
                ms(t.draw),
                ms(t.present)
            );
        }
        s
    }
}

/// The skew between the walls' presents: per frame that every wall presented, the spread
/// between the earliest and the latest first present of it (ms).
#[derive(Clone, Debug, PartialEq)]
pub struct Skew {
    /// The spread of each frame every wall presented, in frame order.
    pub spreads: Vec<f64>,
}

impl Skew {
    /// The `q` quantile (0..=1) of the spreads ([`holocave_protocol::stats::quantile`]:
    /// linear interpolation, numpy's default); `None` when there are none.
    pub fn quantile(&self, q: f64) -> Option<f64> {
        holocave_protocol::stats::quantile(&self.spreads, q)
    }
}

/// The skew from each wall's present log (`(wall, path)`); an unreadable log or a line
/// that is not "FRAME NS" is an error naming the file.
pub fn present_skew(logs: &[(String, PathBuf)]) -> Result<Skew, String> {
    let mut by_frame: BTreeMap<u64, Vec<u128>> = BTreeMap::new();
    for (wall, path) in logs {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("wall {wall}: reading {}: {e}", path.display()))?;
        let mut seen = BTreeSet::new();
        for line in text.lines() {
            let mut parts = line.split_whitespace();
            let (Some(f), Some(ns)) = (parts.next(), parts.next()) else {
                return Err(format!("{}: {line:?} is not \"FRAME NS\"", path.display()));
            };
            let (f, ns): (u64, u128) = (
                f.parse()
                    .map_err(|e| format!("{}: frame {f:?}: {e}", path.display()))?,
                ns.parse()
                    .map_err(|e| format!("{}: time {ns:?}: {e}", path.display()))?,
            );
            // The first present of a frame (a lingering window shows it again).
            if seen.insert(f) {
                by_frame.entry(f).or_default().push(ns);
            }
        }
    }
    let spreads = by_frame
        .values()
        .filter(|t| t.len() == logs.len())
        .map(|t| {
            let (lo, hi) = (t.iter().min().unwrap(), t.iter().max().unwrap());
            (hi - lo) as f64 / 1e6
        })
        .collect();
    Ok(Skew { spreads })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn skew_is_the_spread_of_each_frames_first_presents() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a");
        let b = dir.path().join("b");
        std::fs::write(&a, "1 1000000\n2 2000000\n2 9000000\n3 3000000\n").unwrap();
        std::fs::write(&b, "1 1500000\n2 2000000\n").unwrap();
        let skew = present_skew(&[("a".into(), a.clone()), ("b".into(), b)]).unwrap();
        assert_eq!(skew.spreads, vec![0.5, 0.0], "frame 3 is not on every wall");
        // Linear interpolation between the two spreads, 0 and 0.5 ms.
        assert_eq!(skew.quantile(0.5), Some(0.25));
        assert!((skew.quantile(0.99).unwrap() - 0.495).abs() < 1e-12);
        assert_eq!(skew.quantile(1.0), Some(0.5));
        std::fs::write(&a, "1 x\n").unwrap();
        let e = present_skew(&[("a".into(), a)]).unwrap_err();
        assert!(e.contains("time \"x\""), "{e}");
    }
}
