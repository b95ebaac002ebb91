//! `holocave node --standalone --window` under an Xvfb of the test's own: the window shows
//! what the headless node writes. A still view of the Cornell box at 256×192 for 20
//! frames, the same flags both ways (`--sync`), the headless run without a layout (the
//! wall's own eyes, the pair) and the windowed one in each layout: the layout chooses
//! what is shown, never what is drawn. The screenshot of the window (`xwd -name
//! "holocave front"`) taken while the last frame lingers equals, within one 8-bit step per
//! channel, the headless PNGs of that frame laid out as the layout says — composed here on
//! the CPU, so the GPU's tone mapping (from its own histogram) and layout are checked
//! against the CPU's. (Before a layout stopped choosing the eyes drawn, `--window
//! --layout left` drew the left eye alone and showed a different picture from the pair's
//! left eye: 84% of the pixels within one step, 13% darker on average.) And passive
//! stereo: a wall with two windows shows one eye in each.
//!
//! Both runs use lavapipe's default threads: the render cache's passes give the same
//! result whatever order the GPU runs them in, so a `--sync` run is repeatable.

mod common;
mod xvfb;

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use common::{cornell_front_node, front_node};
use xvfb::{Xvfb, max_difference, stderr_of, wait_for_line};

const FRAMES: u64 = 20;
const W: u32 = 256;
const H: u32 = 192;

/// The standalone node of a still view of the Cornell box, `--sync`, the node's default
/// samples per frame (a sixteenth of the pixels).
fn still_node(config: Option<&Path>) -> Command {
    let mut c = config.map_or_else(cornell_front_node, front_node);
    c.args(["--still", "0,1.5,0", "--sync"]).args([
        "--frames",
        &FRAMES.to_string(),
        "--size",
        &format!("{W}x{H}"),
    ]);
    c
}

/// The same in `layout`.
fn node(layout: &str) -> Command {
    let mut c = still_node(None);
    c.args(["--layout", layout]);
    c
}

fn png(path: &Path) -> image::RgbImage {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8()
}

/// Runs `node` headless into `dir`; its last frame's PNG of each eye, by eye name.
fn headless_eyes(mut node: Command, dir: &Path, what: &str) -> impl Fn(&str) -> image::RgbImage {
    let out = node
        .args(["--headless", "--out"])
        .arg(dir)
        .output()
        .expect("run holocave node --headless");
    assert!(
        out.status.success(),
        "headless {what}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let dir = dir.to_owned();
    move |e: &str| png(&dir.join(format!("front/{:05}-{e}.png", FRAMES - 1)))
}

/// The headless node's last frame (`eye`: by eye name) laid out on the CPU as `layout`.
fn laid_out(layout: &str, eye: &dyn Fn(&str) -> image::RgbImage) -> image::RgbImage {
    match layout {
        "left" => eye("left"),
        "side-by-side" => {
            let (l, r) = (eye("left"), eye("right"));
            image::RgbImage::from_fn(2 * W, H, |x, y| {
                if x < W {
                    *l.get_pixel(x, y)
                } else {
                    *r.get_pixel(x - W, y)
                }
            })
        }
        "top-bottom" => {
            let (l, r) = (eye("left"), eye("right"));
            image::RgbImage::from_fn(W, 2 * H, |x, y| {
                if y < H {
                    *l.get_pixel(x, y)
                } else {
                    *r.get_pixel(x, y - H)
                }
            })
        }
        "anaglyph" => {
            let (l, r) = (eye("left"), eye("right"));
            image::RgbImage::from_fn(W, H, |x, y| {
                let (a, b) = (l.get_pixel(x, y), r.get_pixel(x, y));
                image::Rgb([a[0], b[1], b[2]])
            })
        }
        other => panic!("no CPU layout for {other}"),
    }
}

/// Starts `node` in its window(s) under `x` (lingering on its last frame) and waits until
/// it says the last frame is on screen.
fn lingering(mut node: Command, x: &Xvfb, what: &str) -> Child {
    let mut child = node
        .args(["--window", "--linger", "20"])
        .env("DISPLAY", &x.display)
        .env("WINIT_X11_SCALE_FACTOR", "1")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .stdin(Stdio::null())
        .spawn()
        .expect("run holocave node --window");
    let (lingering, stdout) = wait_for_line(&mut child, "lingering:", Duration::from_secs(120));
    if !lingering {
        let _ = child.kill();
        let _ = child.wait();
        panic!(
            "{what}: the node never lingered\nstdout:\n{stdout}\nstderr:\n{}",
            stderr_of(&mut child)
        );
    }
    child
}

/// A screenshot of the window titled `title`, retried until one matches `expected` within
/// one step or 15 s pass (the X server may show the presented image a moment after the
/// present call returns); the last one.
fn screenshot_of(
    x: &Xvfb,
    title: &str,
    expected: &image::RgbImage,
) -> Result<image::RgbImage, String> {
    let end = Instant::now() + Duration::from_secs(15);
    let mut last = Err("no screenshot taken".to_owned());
    while Instant::now() < end {
        last = x.screenshot(title);
        if let Ok(shot) = &last
            && max_difference(shot, expected).is_some_and(|d| d <= 1)
        {
            break;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    last
}

/// The window's picture of the same run, once its last frame is on screen.
fn windowed(x: &Xvfb, layout: &str, expected: &image::RgbImage) -> image::RgbImage {
    let mut n = node(layout);
    n.args(["--window-pos", "0,0"]);
    let mut child = lingering(n, x, layout);
    let shot = screenshot_of(x, "holocave front", expected);
    let _ = child.kill();
    let _ = child.wait();
    shot.unwrap_or_else(|e| panic!("{layout}: {e}\nstderr:\n{}", stderr_of(&mut child)))
}

#[test]
fn the_window_shows_what_the_headless_node_writes_in_every_layout() {
    let Some(x) = Xvfb::start(640, 480) else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    // HOLOCAVE_KEEP=DIR keeps the pictures for looking at.
    let dir = std::env::var_os("HOLOCAVE_KEEP").map_or(tmp.path().to_owned(), Into::into);
    // What the node records: the wall's eyes, without a layout.
    let recorded = dir.join("headless");
    let eye = headless_eyes(still_node(None), &recorded, "headless");
    for layout in ["left", "side-by-side", "top-bottom", "anaglyph"] {
        let expected = laid_out(layout, &eye);
        // Not a black or flat picture: the comparison would prove little. (The Cornell
        // box fills part of the front wall's view.)
        let lit = expected
            .pixels()
            .filter(|p| p.0.iter().any(|&c| c > 8))
            .count();
        let colours: std::collections::BTreeSet<[u8; 3]> = expected.pixels().map(|p| p.0).collect();
        assert!(
            lit * 8 > expected.pixels().len() && colours.len() > 50,
            "{layout}: only {lit} of {} pixels lit, {} colours, in the headless frame",
            expected.pixels().len(),
            colours.len()
        );
        let shot = windowed(&x, layout, &expected);
        let saved = dir.join(format!("{layout}-window.png"));
        shot.save(&saved).unwrap();
        expected
            .save(dir.join(format!("{layout}-headless.png")))
            .unwrap();
        match max_difference(&shot, &expected) {
            Some(d) => assert!(
                d <= 1,
                "{layout}: the window differs from the headless frame by {d} 8-bit steps (screenshot {})",
                saved.display()
            ),
            None => panic!(
                "{layout}: the window is {:?}, the headless frame {:?}",
                shot.dimensions(),
                expected.dimensions()
            ),
        }
        eprintln!(
            "{layout}: window {:?} equals the headless frame within one step",
            shot.dimensions()
        );
    }
}

/// Passive stereo, one projector per eye: a wall with two windows (`[[wall.window]]`,
/// layouts `left` and `right`) shows the left eye's frame in the first and the right
/// eye's in the second, each equal within one step to the headless node's PNG of that eye.
#[test]
fn two_windows_on_one_wall_show_one_eye_each() {
    let Some(x) = Xvfb::start(640, 480) else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    // The Cornell config with the front wall's two windows, side by side on the screen.
    let shipped = std::fs::read_to_string(common::root().join("configs/cave4-cornell.toml"))
        .expect("the Cornell config");
    let second_wall = shipped
        .match_indices("[[wall]]")
        .nth(1)
        .expect("a second wall")
        .0;
    let windows = format!(
        "[[wall.window]]\nposition = [0, 0]\nlayout = \"left\"\n\
         [[wall.window]]\nposition = [{}, 0]\nlayout = \"right\"\n\n",
        W + 20
    );
    let config = tmp.path().join("passive.toml");
    let text = format!(
        "{}{windows}{}",
        &shipped[..second_wall],
        &shipped[second_wall..]
    );
    std::fs::write(&config, text).unwrap();

    let eye = headless_eyes(still_node(Some(&config)), tmp.path(), "two windows");
    let (left, right) = (eye("left"), eye("right"));
    assert!(
        max_difference(&left, &right).is_some_and(|d| d > 8),
        "the eyes' frames differ, so each window must show its own"
    );

    let mut child = lingering(still_node(Some(&config)), &x, "two windows");
    let shot_of = |title: &str, expected: &image::RgbImage| {
        screenshot_of(&x, title, expected).unwrap_or_else(|e| panic!("{title}: {e}"))
    };
    let first = shot_of("holocave front 0", &left);
    let second = shot_of("holocave front 1", &right);
    let _ = child.kill();
    let _ = child.wait();
    for (title, shot, expected) in [
        ("holocave front 0", &first, &left),
        ("holocave front 1", &second, &right),
    ] {
        let d = max_difference(shot, expected);
        assert!(
            d.is_some_and(|d| d <= 1),
            "{title}: {:?} against the headless eye's {:?}, {d:?} steps apart",
            shot.dimensions(),
            expected.dimensions()
        );
    }
    eprintln!(
        "two windows: the left eye in the first, the right eye in the second, within one step"
    );
}
