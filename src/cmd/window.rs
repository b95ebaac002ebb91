//! `holocave node --window`: the windows of a node's wall (from its config, or one window in
//! `--layout`, placed by `--window-pos` / `--window-size`), and what a frame does with them:
//! the tone mapping from the histogram of the first eye's image (as the headless PNGs have
//! it, but made on the GPU: the frame never leaves it), then every window prepared (drawn
//! on the GPU, waited for) and shown.

use std::io::Write;
use std::path::Path;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::{Context, Result, bail};
use clap::Args;
use holocave_cave::{Eye, Layout, Place, Wall, WindowSettings};
use holocave_protocol::cluster::FrameState;
use holocave_render_node::cluster::Presentation;
use holocave_render_node::present::{Histogrammer, Prepared, layout_eyes};
use holocave_render_node::window::{Screens, WindowSpec};
use holocave_render_node::{DisplayProcess, ToneMapper};

/// The node's window options (flattened into `holocave node`).
#[derive(Args, Clone, Debug, Default)]
pub struct WindowArgs {
    /// Show the wall in windows (its `[[wall.window]]` tables; one window if none) instead
    /// of writing images. Needs a display (X11).
    #[arg(long, conflicts_with = "headless")]
    pub window: bool,
    /// The stereo layout for this run: mono, left, right, side-by-side, top-bottom or
    /// anaglyph (one window, replacing the config's). A standalone wall draws the eyes it
    /// needs; headless, the images written are those eyes'.
    #[arg(long, value_parser = parse_layout)]
    pub layout: Option<Layout>,
    /// After the last frame, keep it on screen this many seconds (windows only).
    #[arg(long, default_value_t = 0.0)]
    pub linger: f64,
    /// Put the (first) window's top-left corner here, X,Y pixels.
    #[arg(long, value_parser = parse_position)]
    pub window_pos: Option<[i32; 2]>,
    /// The (first) window's size, WxH pixels (default: what the layout needs).
    #[arg(long, value_parser = super::parse::size)]
    pub window_size: Option<(u32, u32)>,
    /// Append each presented frame's number and present time (ns since the Unix epoch)
    /// to this file, one "FRAME NS" line per frame.
    #[arg(long)]
    pub present_log: Option<std::path::PathBuf>,
}

fn parse_layout(s: &str) -> Result<Layout, String> {
    Layout::parse(s)
}

fn parse_position(s: &str) -> Result<[i32; 2], String> {
    let v: Vec<i32> = s
        .split(',')
        .map(|p| {
            p.trim()
                .parse::<i32>()
                .map_err(|e| format!("{p:?} in {s:?}: {e}"))
        })
        .collect::<Result<_, _>>()?;
    match v[..] {
        [x, y] => Ok([x, y]),
        _ => Err(format!("{s:?}: expected X,Y in pixels")),
    }
}

impl WindowArgs {
    /// The wall as this run draws it: with `--layout`, a standalone wall draws exactly the
    /// layout's eyes (`adapt_stereo`); in a cluster the master's states decide, and the
    /// layout must show eyes the wall draws.
    pub fn wall_for_run(&self, wall: &Wall, adapt_stereo: bool) -> Result<Wall> {
        let mut wall = wall.clone();
        if let Some(layout) = self.layout {
            if adapt_stereo {
                wall.stereo = layout.stereo();
            }
            wall.windows = vec![WindowSettings::with_layout(layout)];
        }
        if let Some(first) = wall.windows.first_mut() {
            if let Some(p) = self.window_pos {
                first.position = Some(p);
            }
            if let Some((w, h)) = self.window_size {
                first.size = Some([w, h]);
            }
        }
        for (k, w) in wall.windows.iter().enumerate() {
            layout_eyes(w, Eye::for_mode(wall.stereo))
                .map_err(|e| anyhow::anyhow!("wall {:?}, window {k}: {e}", wall.name))?;
        }
        Ok(wall)
    }

    /// The windows of `wall` for eye images of `size`.
    pub fn specs(&self, wall: &Wall, size: (u32, u32)) -> Vec<WindowSpec> {
        let n = wall.windows.len();
        wall.windows
            .iter()
            .enumerate()
            .map(|(k, s)| WindowSpec {
                title: if n == 1 {
                    format!("holocave {}", wall.name)
                } else {
                    format!("holocave {} {k}", wall.name)
                },
                settings: s.clone(),
                size: s.window_size(size),
            })
            .collect()
    }
}

/// A cluster node's windows: each frame prepared before Ready, shown on Swap (then `then`
/// runs, e.g. the presented log), abandoned when a newer state comes first.
pub struct ClusterWindows<'a, F> {
    pub output: WindowOutput<'a>,
    pub then: F,
}

impl<F> Presentation for ClusterWindows<'_, F>
where
    F: FnMut(&FrameState, &mut DisplayProcess) -> Result<(), String>,
{
    fn prepare(&mut self, _: &FrameState, display: &mut DisplayProcess) {
        self.output.prepare(display);
    }

    fn show(&mut self, state: &FrameState, display: &mut DisplayProcess) -> Result<(), String> {
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
}

impl<'a> WindowOutput<'a> {
    pub fn new(
        screens: &'a mut Screens,
        wall: &Wall,
        tone: Option<ToneMapper>,
        log: Option<&Path>,
    ) -> Result<WindowOutput<'a>> {
        let Some(tone) = tone else {
            bail!("--tone reinhard is for PNG previews; windows tone-map with camera or human");
        };
        let eyes = screens
            .presenters
            .iter()
            .map(|p| layout_eyes(&p.settings, Eye::for_mode(wall.stereo)))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| anyhow::anyhow!("wall {:?}: {e}", wall.name))?;
        let log = log
            .map(|p| {
                let f = std::fs::OpenOptions::new()
                    .create(true)
                    .append(true)
                    .open(p)
                    .with_context(|| format!("opening {}", p.display()))?;
                anyhow::Ok((f, p.display().to_string()))
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
        })
    }

    /// Draws the display's images into every window and waits for the GPU (before Ready);
    /// how many windows have a frame ready.
    pub fn prepare(&mut self, display: &DisplayProcess) -> usize {
        // The histogram of the first eye's image, as the headless previews take it.
        let t = Instant::now();
        // The histogram made on the GPU: the frame itself is never read back.
        let (w, h) = display.cache.eye_size(0);
        let hist =
            self.histogrammer
                .histogram(display.cache.gpu(), display.cache.color_buffer(0), w * h);
        self.tone.update_from(hist.as_ref(), false);
        self.tone_time += t.elapsed();
        self.tone_updates += 1;
        let curve = self.tone.curve();
        let mut ready = 0;
        for (p, eyes) in self.screens.presenters.iter_mut().zip(&self.eyes) {
            if p.prepare(&display.cache, *eyes, curve.as_ref()) == Prepared::Ready {
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
    pub fn linger(&mut self, display: &DisplayProcess, seconds: f64, fps: f64, frame: u64) {
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
            let (w, h) = p.surface_size();
            s += &format!(
                "window {k} ({w}x{h}, {}): {} frames drawn, {} shown, {} skipped, {} abandoned; per frame: acquire {:.2} ms, draw + wait {:.2} ms, present {:.2} ms\n",
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

/// `holocave sim --window`: each wall's node opens its window, the windows laid out as the
/// unfolded CAVE (left | front | right, the floor under the front wall; other walls in a
/// row below) and scaled to fit the screen.
#[derive(Args, Clone, Debug, Default)]
pub struct SimWindowArgs {
    /// Show every wall live in a window of its own (needs DISPLAY) instead of writing images.
    #[arg(long)]
    pub window: bool,
    /// The layout of every wall's window (default: the first eye the wall draws).
    #[arg(long, value_parser = parse_layout)]
    pub layout: Option<Layout>,
    /// The screen the windows are laid out to fit, WxH pixels.
    #[arg(long, value_parser = super::parse::size, default_value = "1280x1024")]
    pub screen: (u32, u32),
}

impl SimWindowArgs {
    /// With `--window`, an X display must be named (the nodes would otherwise fail one by
    /// one while the master waits for them).
    pub fn check(&self) -> Result<()> {
        if self.window && std::env::var_os("DISPLAY").is_none_or(|d| d.is_empty()) {
            bail!(
                "--window needs an X display and DISPLAY is not set (without one: Xvfb :1 -screen 0 1280x1024x24 & DISPLAY=:1 holocave sim --window)"
            );
        }
        Ok(())
    }

    /// The node's arguments for `wall` (eye images of `size`): its window placed in the
    /// unfolded CAVE, its present times logged to `DIR/<wall>/present-times.log`; or
    /// `--headless`.
    pub fn node_args(&self, placed: &[Place], wall: &Wall, out: &Path) -> Vec<String> {
        if !self.window {
            return vec!["--headless".to_owned()];
        }
        let layout = self
            .layout
            .unwrap_or_else(|| match Eye::for_mode(wall.stereo)[0] {
                Eye::Left => Layout::Left,
                Eye::Right => Layout::Right,
                Eye::Centre => Layout::Mono,
            });
        let mut a = vec![
            "--window".to_owned(),
            "--layout".to_owned(),
            layout.name().to_owned(),
            "--present-log".to_owned(),
            out.join(&wall.name)
                .join("present-times.log")
                .display()
                .to_string(),
        ];
        if let Some(p) = placed.iter().find(|p| p.wall == wall.name) {
            a.extend([
                "--window-pos".to_owned(),
                format!("{},{}", p.x, p.y),
                "--window-size".to_owned(),
                format!("{}x{}", p.width, p.height),
            ]);
        }
        a
    }
}

/// The skew between the walls' presents of each frame that every wall presented: the
/// spread (latest − earliest present time, ms) per frame, from each wall's present log.
pub fn present_skew(logs: &[(String, std::path::PathBuf)]) -> Result<Vec<f64>> {
    use std::collections::BTreeMap;
    let mut by_frame: BTreeMap<u64, Vec<u128>> = BTreeMap::new();
    for (wall, path) in logs {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("wall {wall}: reading {}", path.display()))?;
        let mut seen = std::collections::BTreeSet::new();
        for line in text.lines() {
            let mut parts = line.split_whitespace();
            let (Some(f), Some(ns)) = (parts.next(), parts.next()) else {
                bail!("{}: {line:?} is not \"FRAME NS\"", path.display());
            };
            let (f, ns): (u64, u128) = (
                f.parse()
                    .with_context(|| format!("{}: frame {f:?}", path.display()))?,
                ns.parse()
                    .with_context(|| format!("{}: time {ns:?}", path.display()))?,
            );
            // The first present of a frame (a lingering window shows it again).
            if seen.insert(f) {
                by_frame.entry(f).or_default().push(ns);
            }
        }
    }
    Ok(by_frame
        .values()
        .filter(|t| t.len() == logs.len())
        .map(|t| {
            let (lo, hi) = (t.iter().min().unwrap(), t.iter().max().unwrap());
            (hi - lo) as f64 / 1e6
        })
        .collect())
}

/// The `q` quantile (0..=1) of `values` (nearest rank); `None` when empty.
pub fn quantile(values: &[f64], q: f64) -> Option<f64> {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let i = ((q * v.len() as f64).ceil() as usize).clamp(1, v.len().max(1)) - 1;
    v.get(i).copied()
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
        assert_eq!(skew, vec![0.5, 0.0], "frame 3 is not on every wall");
        assert_eq!(quantile(&skew, 0.5), Some(0.0));
        assert_eq!(quantile(&skew, 0.99), Some(0.5));
        std::fs::write(&a, "1 x\n").unwrap();
        let e = present_skew(&[("a".into(), a)]).unwrap_err();
        assert!(format!("{e:#}").contains("time \"x\""), "{e:#}");
    }
}
