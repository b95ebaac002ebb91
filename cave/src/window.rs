//! A wall's windows: where each one shows (monitor, position, size, fullscreen), how it lays
//! out the wall's eyes (stereo layout, swapped eyes, flips for rear projection) and how it
//! presents. Written as `[[wall.window]]` tables ([`WindowConfig`]), checked by
//! [`check_windows`] into [`WindowSettings`]. A wall without a table gets one window with
//! the default layout of its stereo mode ([`WindowSettings::for_stereo`]).
//!
//! Frame-sequential (quad-buffered) stereo is refused: wgpu's swapchains have one layer.

use serde::{Deserialize, Serialize};

use crate::config::StereoMode;
use crate::frustum::Eye;
use crate::size::Size;

/// Largest window side or position (pixels) a config may ask for.
pub const MAX_WINDOW_PIXELS: i64 = 16_384;

/// Why quad-buffered stereo is refused (shown in the config error).
pub const NO_QUAD_BUFFER: &str = "frame-sequential (quad-buffered) stereo is not possible: wgpu creates single-layer swapchains; use side-by-side or top-bottom for a projector in 3-D mode, anaglyph on a desktop, or two windows on the wall (layout left and right, one projector per eye)";

/// A monitor as written: its index in the list the system gives, or its name.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum MonitorConfig {
    Index(i64),
    Name(String),
}

/// One `[[wall.window]]` table as written. Every field is optional.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WindowConfig {
    /// The monitor (index or name); default: the primary one.
    pub monitor: Option<MonitorConfig>,
    /// Top-left corner in pixels, relative to the monitor's (needed where no window
    /// manager places windows).
    pub position: Option<[i64; 2]>,
    /// Window size in pixels; default: what the layout needs at the wall's pixels.
    pub size: Option<[i64; 2]>,
    /// `"no"` (default), `"borderless"` or `"exclusive"`.
    pub fullscreen: Option<String>,
    /// `mono`, `left`, `right`, `side-by-side`, `top-bottom` or `anaglyph`.
    pub layout: Option<String>,
    /// Side-by-side or top-bottom with each eye squeezed into half the window (projectors
    /// in 3-D mode) instead of a window twice the wall's size.
    pub squeezed: bool,
    /// Left-eye picture where the right eye's goes and vice versa.
    pub swap_eyes: bool,
    /// `"none"` (default), `"horizontal"`, `"vertical"` or `"both"` (rear projection).
    pub flip: Option<String>,
    /// `"fifo"` (default), `"mailbox"` or `"immediate"`.
    pub present_mode: Option<String>,
    /// Show the mouse cursor over the window (default: hidden).
    pub cursor: bool,
}

/// Where a window goes on which monitor.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Monitor {
    Index(usize),
    Name(String),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fullscreen {
    No,
    /// A borderless window covering the monitor at its current mode.
    Borderless,
    /// The monitor switched to a video mode of the window's size.
    Exclusive,
}

/// How a window shows the wall's eyes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// The view from between the eyes.
    Mono,
    Left,
    Right,
    /// Left eye in the left half, right eye in the right half.
    SideBySide,
    /// Left eye in the top half, right eye in the bottom half.
    TopBottom,
    /// Red from the left eye, green and blue from the right (red-cyan glasses).
    Anaglyph,
}

impl Layout {
    pub const NAMES: &'static str = "mono, left, right, side-by-side, top-bottom, anaglyph";

    /// A layout by name; quad-buffered stereo is refused with the reason.
    pub fn parse(name: &str) -> Result<Layout, String> {
        Ok(match name {
            "mono" => Layout::Mono,
            "left" => Layout::Left,
            "right" => Layout::Right,
            "side-by-side" => Layout::SideBySide,
            "top-bottom" => Layout::TopBottom,
            "anaglyph" => Layout::Anaglyph,
            "frame-sequential" | "quad-buffered" | "quad-buffer" | "active" => {
                return Err(format!("{name:?}: {NO_QUAD_BUFFER}"));
            }
            other => return Err(format!("{other:?} is not a layout ({})", Layout::NAMES)),
        })
    }

    pub fn name(self) -> &'static str {
        match self {
            Layout::Mono => "mono",
            Layout::Left => "left",
            Layout::Right => "right",
            Layout::SideBySide => "side-by-side",
            Layout::TopBottom => "top-bottom",
            Layout::Anaglyph => "anaglyph",
        }
    }

    /// The eyes the layout shows.
    pub fn eyes(self) -> &'static [Eye] {
        match self {
            Layout::Mono => &[Eye::Centre],
            Layout::Left => &[Eye::Left],
            Layout::Right => &[Eye::Right],
            Layout::SideBySide | Layout::TopBottom | Layout::Anaglyph => &[Eye::Left, Eye::Right],
        }
    }

    /// The stereo mode that draws exactly the eyes this layout shows.
    pub fn stereo(self) -> StereoMode {
        match self {
            Layout::Mono => StereoMode::Mono,
            Layout::Left => StereoMode::Left,
            Layout::Right => StereoMode::Right,
            _ => StereoMode::Pair,
        }
    }

    /// The layout a wall of this stereo mode gets unless told.
    pub fn for_stereo(stereo: StereoMode) -> Layout {
        match stereo {
            StereoMode::Pair => Layout::SideBySide,
            StereoMode::Mono => Layout::Mono,
            StereoMode::Left => Layout::Left,
            StereoMode::Right => Layout::Right,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PresentMode {
    /// Wait for the display's refresh (never tears; the only mode every driver has).
    Fifo,
    /// The newest frame at each refresh, never waiting.
    Mailbox,
    /// At once (may tear).
    Immediate,
}

impl PresentMode {
    pub fn name(self) -> &'static str {
        match self {
            PresentMode::Fifo => "fifo",
            PresentMode::Mailbox => "mailbox",
            PresentMode::Immediate => "immediate",
        }
    }
}

/// A checked window of a wall.
#[derive(Clone, Debug, PartialEq)]
pub struct WindowSettings {
    pub monitor: Option<Monitor>,
    pub position: Option<[i32; 2]>,
    pub size: Option<Size>,
    pub fullscreen: Fullscreen,
    pub layout: Layout,
    pub squeezed: bool,
    pub swap_eyes: bool,
    pub flip_x: bool,
    pub flip_y: bool,
    pub present_mode: PresentMode,
    pub cursor: bool,
}

impl WindowSettings {
    /// One window in the default layout of `stereo`, placed by the system.
    pub fn for_stereo(stereo: StereoMode) -> WindowSettings {
        WindowSettings::with_layout(Layout::for_stereo(stereo))
    }

    /// One window in `layout`, placed by the system, fifo.
    pub fn with_layout(layout: Layout) -> WindowSettings {
        WindowSettings {
            monitor: None,
            position: None,
            size: None,
            fullscreen: Fullscreen::No,
            layout,
            squeezed: false,
            swap_eyes: false,
            flip_x: false,
            flip_y: false,
            present_mode: PresentMode::Fifo,
            cursor: false,
        }
    }

    /// The window's size for eye images of `eye` pixels: the configured size, or what
    /// the layout needs to show every eye pixel once (twice the width side by side,
    /// twice the height top-bottom, unless squeezed).
    pub fn window_size(&self, eye: Size) -> Size {
        if let Some(size) = self.size {
            return size;
        }
        match (self.layout, self.squeezed) {
            (Layout::SideBySide, false) => Size::new(eye.width * 2, eye.height),
            (Layout::TopBottom, false) => Size::new(eye.width, eye.height * 2),
            _ => eye,
        }
    }

    /// One line for `holocave cave check`.
    pub fn describe(&self) -> String {
        let mut s = match &self.monitor {
            None => "primary monitor".to_owned(),
            Some(Monitor::Index(i)) => format!("monitor {i}"),
            Some(Monitor::Name(n)) => format!("monitor {n:?}"),
        };
        match self.size {
            Some(size) => s += &format!(", {size}"),
            None => s += ", size from the layout",
        }
        if let Some([x, y]) = self.position {
            s += &format!(" at ({x}, {y})");
        }
        s += match self.fullscreen {
            Fullscreen::No => ", windowed",
            Fullscreen::Borderless => ", borderless fullscreen",
            Fullscreen::Exclusive => ", exclusive fullscreen",
        };
        s += &format!(", {}", self.layout.name());
        if self.squeezed {
            s += " (squeezed)";
        }
        if self.swap_eyes {
            s += ", eyes swapped";
        }
        match (self.flip_x, self.flip_y) {
            (true, true) => s += ", flipped both ways",
            (true, false) => s += ", flipped horizontally",
            (false, true) => s += ", flipped vertically",
            _ => {}
        }
        s += &format!(", {}", self.present_mode.name());
        s += if self.cursor {
            ", cursor shown"
        } else {
            ", cursor hidden"
        };
        s
    }
}

/// Checks the windows of the wall at `at` (a field prefix such as `wall[0] ("front")`)
/// whose stereo mode is `stereo`; every problem goes to `problems`, naming its field.
/// No tables: one window in the default layout.
pub fn check_windows(
    at: &str,
    stereo: StereoMode,
    windows: &[WindowConfig],
    problems: &mut Vec<String>,
) -> Vec<WindowSettings> {
    if windows.is_empty() {
        return vec![WindowSettings::for_stereo(stereo)];
    }
    windows
        .iter()
        .enumerate()
        .map(|(k, w)| check_window(&format!("{at}.window[{k}]"), stereo, w, problems))
        .collect()
}

fn check_window(
    at: &str,
    stereo: StereoMode,
    w: &WindowConfig,
    problems: &mut Vec<String>,
) -> WindowSettings {
    let mut s = WindowSettings::for_stereo(stereo);
    s.monitor = match &w.monitor {
        None => None,
        Some(MonitorConfig::Index(i)) if *i >= 0 => Some(Monitor::Index(*i as usize)),
        Some(MonitorConfig::Index(i)) => {
            problems.push(format!("{at}.monitor: index {i} must be 0 or more"));
            None
        }
        Some(MonitorConfig::Name(n)) if !n.trim().is_empty() => Some(Monitor::Name(n.clone())),
        Some(MonitorConfig::Name(_)) => {
            problems.push(format!("{at}.monitor: an empty name"));
            None
        }
    };
    if let Some([x, y]) = w.position {
        if x.abs() > MAX_WINDOW_PIXELS || y.abs() > MAX_WINDOW_PIXELS {
            problems.push(format!(
                "{at}.position: [{x}, {y}] is beyond ±{MAX_WINDOW_PIXELS} pixels"
            ));
        } else {
            s.position = Some([x as i32, y as i32]);
        }
    }
    if let Some([width, height]) = w.size {
        if !(1..=MAX_WINDOW_PIXELS).contains(&width) || !(1..=MAX_WINDOW_PIXELS).contains(&height) {
            problems.push(format!(
                "{at}.size: [{width}, {height}] must be 1 to {MAX_WINDOW_PIXELS} pixels each way"
            ));
        } else {
            s.size = Some(Size::new(width as u32, height as u32));
        }
    }
    s.fullscreen = match w.fullscreen.as_deref() {
        None | Some("no") => Fullscreen::No,
        Some("borderless") => Fullscreen::Borderless,
        Some("exclusive") => Fullscreen::Exclusive,
        Some(other) => {
            problems.push(format!(
                "{at}.fullscreen: {other:?} is not one of no, borderless, exclusive"
            ));
            Fullscreen::No
        }
    };
    if let Some(name) = &w.layout {
        match Layout::parse(name) {
            Ok(layout) => s.layout = layout,
            Err(e) => problems.push(format!("{at}.layout: {e}")),
        }
    }
    let drawn = Eye::for_mode(stereo);
    if let Some(missing) = s.layout.eyes().iter().find(|e| !drawn.contains(e)) {
        problems.push(format!(
            "{at}.layout: {} shows the {missing:?} eye, which a wall with stereo = {:?} does not draw",
            s.layout.name(),
            format!("{stereo:?}").to_lowercase()
        ));
    }
    s.squeezed = w.squeezed;
    if w.squeezed && !matches!(s.layout, Layout::SideBySide | Layout::TopBottom) {
        problems.push(format!(
            "{at}.squeezed: only side-by-side and top-bottom layouts can be squeezed, not {}",
            s.layout.name()
        ));
    }
    s.swap_eyes = w.swap_eyes;
    (s.flip_x, s.flip_y) = match w.flip.as_deref() {
        None | Some("none") => (false, false),
        Some("horizontal") => (true, false),
        Some("vertical") => (false, true),
        Some("both") => (true, true),
        Some(other) => {
            problems.push(format!(
                "{at}.flip: {other:?} is not one of none, horizontal, vertical, both"
            ));
            (false, false)
        }
    };
    s.present_mode = match w.present_mode.as_deref() {
        None | Some("fifo") => PresentMode::Fifo,
        Some("mailbox") => PresentMode::Mailbox,
        Some("immediate") => PresentMode::Immediate,
        Some(other) => {
            problems.push(format!(
                "{at}.present_mode: {other:?} is not one of fifo, mailbox, immediate"
            ));
            PresentMode::Fifo
        }
    };
    s.cursor = w.cursor;
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(stereo: StereoMode, toml_text: &str) -> (Vec<WindowSettings>, Vec<String>) {
        #[derive(Deserialize)]
        struct W {
            window: Vec<WindowConfig>,
        }
        let w: W = toml::from_str(toml_text).unwrap();
        let mut problems = Vec::new();
        let s = check_windows("wall[0] (\"front\")", stereo, &w.window, &mut problems);
        (s, problems)
    }

    #[test]
    fn a_full_window_table_is_read() {
        let (s, p) = check(
            StereoMode::Pair,
            r#"
            [[window]]
            monitor = "DP-1"
            position = [10, -20]
            size = [1024, 768]
            fullscreen = "borderless"
            layout = "top-bottom"
            squeezed = true
            swap_eyes = true
            flip = "horizontal"
            present_mode = "mailbox"
            [[window]]
            monitor = 1
            layout = "right"
            "#,
        );
        assert!(p.is_empty(), "{p:?}");
        assert_eq!(s.len(), 2);
        assert_eq!(s[0].monitor, Some(Monitor::Name("DP-1".into())));
        assert_eq!(s[0].position, Some([10, -20]));
        assert_eq!(s[0].window_size(Size::new(4, 3)), Size::new(1024, 768));
        assert_eq!(s[0].fullscreen, Fullscreen::Borderless);
        assert_eq!(s[0].layout, Layout::TopBottom);
        assert!(s[0].squeezed && s[0].swap_eyes && s[0].flip_x && !s[0].flip_y);
        assert_eq!(s[0].present_mode, PresentMode::Mailbox);
        assert_eq!(s[1].monitor, Some(Monitor::Index(1)));
        assert_eq!(s[1].layout, Layout::Right);
        assert_eq!(s[1].window_size(Size::new(4, 3)), Size::new(4, 3));
        assert!(!s[1].cursor);
    }

    #[test]
    fn no_table_is_one_window_in_the_stereo_modes_layout() {
        let mut p = Vec::new();
        let s = check_windows("w", StereoMode::Pair, &[], &mut p);
        assert_eq!(s, vec![WindowSettings::with_layout(Layout::SideBySide)]);
        assert_eq!(s[0].window_size(Size::new(4, 3)), Size::new(8, 3));
        let s = check_windows("w", StereoMode::Mono, &[], &mut p);
        assert_eq!(s[0].layout, Layout::Mono);
        assert!(p.is_empty());
    }

    #[test]
    fn problems_name_the_window_field() {
        let (_, p) = check(
            StereoMode::Mono,
            r#"
            [[window]]
            monitor = -1
            position = [0, 99999]
            size = [0, 768]
            fullscreen = "yes"
            layout = "side-by-side"
            flip = "diagonal"
            present_mode = "vsync"
            [[window]]
            layout = "quad-buffered"
            [[window]]
            layout = "mono"
            squeezed = true
            "#,
        );
        let all = p.join("\n");
        for expected in [
            "wall[0] (\"front\").window[0].monitor: index -1",
            "window[0].position: [0, 99999]",
            "window[0].size: [0, 768]",
            "window[0].fullscreen: \"yes\"",
            "window[0].layout: side-by-side shows the Left eye, which a wall with stereo = \"mono\" does not draw",
            "window[0].flip: \"diagonal\"",
            "window[0].present_mode: \"vsync\"",
            "window[1].layout: \"quad-buffered\": frame-sequential (quad-buffered) stereo is not possible: wgpu creates single-layer swapchains",
            "window[2].squeezed: only side-by-side and top-bottom",
        ] {
            assert!(all.contains(expected), "missing {expected:?} in:\n{all}");
        }
    }

    #[test]
    fn unknown_window_fields_are_refused() {
        #[derive(Debug, Deserialize)]
        #[allow(dead_code)]
        struct W {
            window: Vec<WindowConfig>,
        }
        let e = toml::from_str::<W>("[[window]]\nstereo_mode = \"x\"\n").unwrap_err();
        assert!(e.to_string().contains("stereo_mode"), "{e}");
    }
}
