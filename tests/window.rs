//! `holocave node --standalone --window` under an Xvfb of the test's own: the window shows
//! what the headless node writes. A still view of the Cornell box, the same frames, flags
//! and seed both ways (`--sync`); the screenshot of the window (`xwd -name "holocave
//! front"`) taken while the last frame lingers equals, within one 8-bit step per
//! channel, the headless PNGs of that frame laid out as the layout says — composed here on
//! the CPU, so the GPU's tone mapping and layout are checked against the CPU's.

mod common;
mod xvfb;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::cornell_front_node;
use xvfb::{Xvfb, max_difference, stderr_of, wait_for_line};

const FRAMES: u64 = 6;
const W: u32 = 40;
const H: u32 = 30;

/// The standalone node of a still view of the Cornell box in `layout`, `--sync`.
fn node(layout: &str) -> Command {
    let mut c = cornell_front_node();
    c.args(["--still", "0.1,1.4,0.3", "--sync"])
        .args([
            "--frames",
            &FRAMES.to_string(),
            "--size",
            &format!("{W}x{H}"),
        ])
        .args(["--samples", &(W * H / 2).to_string(), "--layout", layout]);
    c
}

/// One lavapipe thread: the render cache's insert pass lets samples race for a group's
/// slots, so with several GPU threads two runs may keep different samples (seen here about
/// once in six windowed runs); on one thread a `--sync` run is repeatable, and the test
/// compares presentation, not the cache's races.
const GPU_THREADS: (&str, &str) = ("LP_NUM_THREADS", "1");

fn png(path: &Path) -> image::RgbImage {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8()
}

/// The headless node's last frame in `layout`, laid out on the CPU.
fn headless(layout: &str, dir: &Path) -> image::RgbImage {
    let out = node(layout)
        .env(GPU_THREADS.0, GPU_THREADS.1)
        .args(["--headless", "--out"])
        .arg(dir)
        .output()
        .expect("run holocave node --headless");
    assert!(
        out.status.success(),
        "headless {layout}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let eye = |e: &str| png(&dir.join(format!("front/{:05}-{e}.png", FRAMES - 1)));
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

/// The window's picture of the same run: started under `x`, screenshot once the last frame
/// is on screen (the node says so, then lingers). Screenshots are retried until one
/// matches `expected` or the linger ends (the X server may show the presented image a
/// moment after the present call returns); the last one is returned.
fn windowed(x: &Xvfb, layout: &str, expected: &image::RgbImage) -> image::RgbImage {
    let mut child = node(layout)
        .args(["--window", "--linger", "20", "--window-pos", "0,0"])
        .env("DISPLAY", &x.display)
        .env("WINIT_X11_SCALE_FACTOR", "1")
        .env(GPU_THREADS.0, GPU_THREADS.1)
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
            "{layout}: the node never lingered\nstdout:\n{stdout}\nstderr:\n{}",
            stderr_of(&mut child)
        );
    }
    let end = Instant::now() + Duration::from_secs(15);
    let mut last = Err("no screenshot taken".to_owned());
    while Instant::now() < end {
        last = x.screenshot("holocave front");
        if let Ok(shot) = &last
            && max_difference(shot, expected).is_some_and(|d| d <= 1)
        {
            break;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    let _ = child.kill();
    let _ = child.wait();
    last.unwrap_or_else(|e| panic!("{layout}: {e}\nstderr:\n{}", stderr_of(&mut child)))
}

#[test]
fn the_window_shows_what_the_headless_node_writes_in_every_layout() {
    let Some(x) = Xvfb::start(640, 480) else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    // HOLOCAVE_KEEP=DIR keeps the pictures for looking at.
    let dir = std::env::var_os("HOLOCAVE_KEEP").map_or(tmp.path().to_owned(), Into::into);
    for layout in ["left", "side-by-side", "top-bottom", "anaglyph"] {
        let expected = headless(layout, &dir.join(layout));
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
