//! `holocave node --standalone --headless` end to end: a few stereo frames of the Cornell
//! box through the front wall, written where the issue says, showing what they should:
//! finite radiance, nothing before the first samples, then a picture that fills in, a
//! different one per eye, its tone-mapped PNG and the pixels each frame chose.

mod common;

use std::path::{Path, PathBuf};

use common::cornell_front_node;
use glam::Vec3;
use holocave_tracer::film::Image;

const FRAMES: u64 = 8;
const W: u32 = 32;
const H: u32 = 24;
/// Pixels each eye traces per frame: the node's default, a sixteenth of its pixels.
const BUDGET: u32 = W * H / 16;

fn lum(p: Vec3) -> f32 {
    holocave_scene::luminance(p)
}

/// Fraction of the pixels with some light.
fn lit(img: &Image) -> f64 {
    img.pixels.iter().filter(|&&p| lum(p) > 0.0).count() as f64 / img.pixels.len() as f64
}

fn png(path: &Path) -> image::RgbImage {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8()
}

#[test]
fn standalone_headless_node_writes_both_eyes_per_frame() {
    let dir = std::env::temp_dir().join(format!("holocave-node-test-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    run_the_node(&dir);
    let images: Vec<[Image; 2]> = (0..FRAMES)
        .map(|frame| ["left", "right"].map(|eye| read_one_eyes_frame(&dir, frame, eye)))
        .collect();
    check_the_picture_fills_in(&images);
    check_every_frame_is_new_and_the_eyes_differ(&images);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Runs `holocave node --standalone --headless` for `FRAMES` frames writing its debug
/// images to `dir`, and checks it succeeded.
fn run_the_node(dir: &Path) {
    let frames = FRAMES.to_string();
    let size = format!("{W}x{H}");
    let out = cornell_front_node()
        .args([
            "--tracker",
            "synthetic:walk",
            "--headless",
            "--sync",
            "--frames",
            &frames,
            "--size",
            &size,
            "--debug-images",
            "--out",
        ])
        .arg(dir)
        .output()
        .expect("run holocave node");
    assert!(
        out.status.success(),
        "holocave node failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The front wall's file of `frame` for `eye` with `suffix`, which must exist.
fn written(dir: &Path, frame: u64, eye: &str, suffix: &str) -> PathBuf {
    let f = dir.join(format!("front/{frame:05}-{eye}{suffix}"));
    assert!(f.exists(), "{} missing", f.display());
    f
}

/// One eye's EXR of one frame, checked: its size, finite radiance that is not negative,
/// its PNG black exactly where it is, its priority image there, and exactly the eye's
/// budget of pixels chosen.
fn read_one_eyes_frame(dir: &Path, frame: u64, eye: &str) -> Image {
    let img = Image::read_exr(&written(dir, frame, eye, ".exr")).expect("read the EXR");
    assert_eq!((img.width, img.height), (W, H), "frame {frame} {eye}: size");
    assert!(
        img.pixels
            .iter()
            .all(|p| p.is_finite() && p.min_element() >= 0.0),
        "frame {frame} {eye}: a negative or non-finite radiance"
    );
    // The PNG is the EXR tone mapped: black exactly where the EXR is black.
    let preview = png(&written(dir, frame, eye, ".png"));
    assert_eq!(
        preview.dimensions(),
        (W, H),
        "frame {frame} {eye}: PNG size"
    );
    for (p, q) in img.pixels.iter().zip(preview.pixels()) {
        assert_eq!(
            lum(*p) > 0.0,
            q.0 != [0, 0, 0],
            "frame {frame} {eye}: PNG {q:?} for radiance {p}"
        );
    }
    written(dir, frame, eye, "-priority.png");
    // The pixels chosen this frame: exactly the eye's budget (the render cache
    // cuts or tops up the dither's choice).
    let chosen = png(&written(dir, frame, eye, "-chosen.png"))
        .pixels()
        .filter(|q| q.0 != [0, 0, 0])
        .count() as u32;
    assert_eq!(
        chosen, BUDGET,
        "frame {frame} {eye}: {chosen} pixels chosen for a budget of {BUDGET}"
    );
    eprintln!(
        "frame {frame} {eye}: {:.0}% lit, mean luminance {:.4}, {chosen} chosen",
        lit(&img) * 100.0,
        img.pixels.iter().map(|&p| lum(p)).sum::<f32>() / (W * H) as f32
    );
    img
}

/// Frame 0 is drawn before any sample has come back: black. Then the picture fills in.
fn check_the_picture_fills_in(images: &[[Image; 2]]) {
    for (e, img) in images[0].iter().enumerate() {
        assert_eq!(
            lit(img),
            0.0,
            "frame 0 eye {e}: drawn before any sample, yet lit"
        );
    }
    let last_frame = &images[FRAMES as usize - 1];
    for (e, (one, end)) in images[1].iter().zip(last_frame).enumerate() {
        let (first, last) = (lit(one), lit(end));
        assert!(first > 0.0, "eye {e}: frame 1 is black");
        // The lit box fills about a fifth of this view (21% seen at frame 7; the rest is
        // the black of rays that escaped), the first frame's 48 samples and their
        // neighbours 14%.
        assert!(
            last > 0.1 && last >= first,
            "eye {e}: {:.0}% of the pixels lit at frame 1, {:.0}% at the last frame",
            first * 100.0,
            last * 100.0
        );
    }
}

/// Every frame shows something new (more samples, a moving head), and the eyes differ.
fn check_every_frame_is_new_and_the_eyes_differ(images: &[[Image; 2]]) {
    for (f, pair) in images.windows(2).enumerate().map(|(i, w)| (i + 1, w)) {
        for (e, (now, before)) in pair[1].iter().zip(&pair[0]).enumerate() {
            assert_ne!(
                now.pixels,
                before.pixels,
                "eye {e}: frame {f} repeats frame {}",
                f - 1
            );
        }
        assert_ne!(
            pair[1][0].pixels, pair[1][1].pixels,
            "frame {f}: both eyes show the same picture"
        );
    }
}
