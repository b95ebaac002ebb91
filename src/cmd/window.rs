//! The window flags: `holocave node --window` (the windows of a node's wall from its
//! config, or one window in `--layout`, placed by `--window-pos` / `--window-size`) and
//! `holocave sim --window` (every wall's window placed in the unfolded CAVE). What a frame
//! does with the windows is `holocave_render_node::present::wall_windows`.

use std::path::Path;

use anyhow::{Result, bail};
use clap::Args;
use holocave_cave::{Eye, Layout, Place, Size, Wall, WindowSettings};
use holocave_render_node::present::layout_eyes;
use holocave_render_node::present::window::WindowSpec;

/// The node's window options (flattened into `holocave node`).
#[derive(Args, Clone, Debug, Default)]
pub struct WindowArgs {
    /// Show the wall in windows (its `[[wall.window]]` tables; one window if none) instead
    /// of writing images. Needs a display (X11).
    #[arg(long, conflicts_with = "headless")]
    pub window: bool,
    /// The stereo layout for this run: mono, left, right, side-by-side, top-bottom or
    /// anaglyph (one window, replacing the config's). It chooses what is shown, not what
    /// is drawn: a standalone wall draws its own eyes (so a window shows what the node
    /// writes headless), or the layout's where it shows an eye the wall does not draw.
    #[arg(long, value_parser = parse_layout)]
    pub layout: Option<Layout>,
    /// After the last frame, keep it on screen this many seconds (windows only).
    #[arg(long, default_value_t = 0.0)]
    pub linger: f64,
    /// Put the (first) window's top-left corner here, X,Y pixels.
    #[arg(long, value_parser = parse_position)]
    pub window_pos: Option<[i32; 2]>,
    /// The (first) window's size, WxH pixels (default: what the layout needs).
    #[arg(long)]
    pub window_size: Option<Size>,
    /// Append each presented frame's number and present time (ns since the Unix epoch)
    /// to this file, one "FRAME NS" line per frame.
    #[arg(long)]
    pub present_log: Option<std::path::PathBuf>,
}

fn parse_layout(s: &str) -> Result<Layout, String> {
    Layout::parse(s)
}

fn parse_position(s: &str) -> Result<[i32; 2], String> {
    super::parse::list(s, "X,Y in pixels")
}

impl WindowArgs {
    /// The wall as this run draws it: with `--layout`, a standalone wall (`adapt_stereo`)
    /// keeps its eyes if they include the layout's (the render cache's eyes share their
    /// samples, so drawing fewer eyes would show another picture) and draws the layout's
    /// eyes otherwise; in a cluster the master's states decide, and the layout must show
    /// eyes the wall draws.
    pub fn wall_for_run(&self, wall: &Wall, adapt_stereo: bool) -> Result<Wall> {
        let mut wall = wall.clone();
        if let Some(layout) = self.layout {
            let drawn = Eye::for_mode(wall.stereo);
            if adapt_stereo && !layout.eyes().iter().all(|e| drawn.contains(e)) {
                wall.stereo = layout.stereo();
            }
            wall.windows = vec![WindowSettings::with_layout(layout)];
        }
        if let Some(first) = wall.windows.first_mut() {
            if let Some(p) = self.window_pos {
                first.position = Some(p);
            }
            if let Some(size) = self.window_size {
                first.size = Some(size);
            }
        }
        for (k, w) in wall.windows.iter().enumerate() {
            layout_eyes(w, Eye::for_mode(wall.stereo))
                .map_err(|e| anyhow::anyhow!("wall {:?}, window {k}: {e}", wall.name))?;
        }
        Ok(wall)
    }

    /// The windows of `wall` for eye images of `size`.
    pub fn specs(&self, wall: &Wall, size: Size) -> Vec<WindowSpec> {
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

/// `holocave sim --window`: each wall's node opens its window, the windows laid out as the
/// unfolded CAVE (left | front | right, the floor under the front wall; other walls in a
/// row below) and scaled to fit the screen.
#[derive(Args, Clone, Debug)]
pub struct SimWindowArgs {
    /// Show every wall live in a window of its own (needs DISPLAY) instead of writing images.
    #[arg(long)]
    pub window: bool,
    /// The layout of every wall's window (default: the first eye the wall draws).
    #[arg(long, value_parser = parse_layout)]
    pub layout: Option<Layout>,
    /// The desktop the windows are laid out to fit, WxH pixels.
    #[arg(long, default_value = "1280x1024")]
    pub desktop: Size,
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

    /// The node's arguments for `wall`: its window placed in the unfolded CAVE (at
    /// `placed`'s size), its present times logged to `DIR/<wall>/present-times.log`; or
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
                p.size.to_string(),
            ]);
        }
        a
    }
}
