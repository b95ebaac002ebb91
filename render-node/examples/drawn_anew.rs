//! Which pixels a moving eye's frame draws anew and which it carries from its last frame
//! (`holocave_vlf::carry`), as a picture: the room's front and floor walls, the left eye at
//! 128 × 96, the head walking sideways at 30 cm/s drawn at 15 Hz (2 cm a frame). Each
//! wall's panel shows the frame as drawn beside the same frame with the pixels drawn anew
//! in red (traced, their light estimated) and the carried ones in grey.
//!
//! ```text
//! cargo run --release -- sim --frames 1        # bakes out/sim/room.vlf once
//! cargo run --release -p holocave-render-node --example drawn_anew -- \
//!     out/sim/room.vlf docs/drawn-anew.png
//! ```

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::Context;
use glam::Vec3;
use holocave_cave::{Size, WallView};
use holocave_render_node::{EyeView, VlfBase};
use holocave_scene::color::luminance;
use holocave_scene::{LoadOptions, Scene};
use holocave_tracer::film::Image;
use holocave_vlf::view::shade;

const EXPOSURE: f32 = 0.6;
const FRAMES: usize = 12;

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let field = PathBuf::from(args.next().context("usage: drawn_anew FIELD.vlf OUT.png")?);
    let out = PathBuf::from(args.next().context("usage: drawn_anew FIELD.vlf OUT.png")?);
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let scene = Arc::new(Scene::load(
        &root.join("scenes/room.gltf"),
        &LoadOptions::default(),
    )?);
    let walls = [front(), floor()];
    let panels: Vec<Image> = walls
        .iter()
        .map(|&wall| panel(&field, &scene, wall))
        .collect::<anyhow::Result<_>>()?;
    let (w, h) = (panels[0].width, panels[0].height);
    let mut picture = Image::new(w, h * panels.len() as u32);
    for (k, p) in panels.iter().enumerate() {
        let at = k * (w * h) as usize;
        picture.pixels[at..at + p.pixels.len()].copy_from_slice(&p.pixels);
    }
    picture.write_png(&out, EXPOSURE)?;
    println!("{}", out.display());
    Ok(())
}

/// One wall's frame after the eye walked `FRAMES` frames, and beside it which of its
/// pixels were drawn anew.
fn panel(field: &std::path::Path, scene: &Arc<Scene>, wall: WallView) -> anyhow::Result<Image> {
    let base = VlfBase::open(field, scene.clone())?;
    let view = |k: usize| {
        let mut w = wall;
        w.eye.x += 0.02 * k as f32;
        EyeView::looking_at(w, 0.05).expect("the eye is in front of the wall")
    };
    let mut lookups = Vec::new();
    for k in 0..=FRAMES {
        lookups = base.lookups(0, &view(k));
    }
    let last = view(FRAMES).wall;
    let anew = base.drawn_anew(0, &last).context("the eye's last frame")?;
    let drawn = shade(&lookups, base.values());
    let (w, h) = (last.size.width as usize, last.size.height as usize);
    let share = anew.iter().filter(|&&a| a).count() as f32 / anew.len() as f32;
    println!("{:.0} % of the pixels drawn anew", share * 100.0);
    let mut image = Image::new(2 * w as u32, h as u32);
    for y in 0..h {
        for x in 0..w {
            let (i, c) = (y * w + x, drawn[y * w + x]);
            image.pixels[y * 2 * w + x] = c;
            image.pixels[y * 2 * w + w + x] = if anew[i] {
                Vec3::new(20.0 / EXPOSURE, 0.0, 0.0)
            } else {
                Vec3::splat(luminance(c))
            };
        }
    }
    Ok(image)
}

/// The left eye 1.6 m up in the middle of the CAVE of `configs/cave4-room.toml`.
fn eye() -> Vec3 {
    Vec3::new(-0.032, 1.6, 0.0)
}

fn front() -> WallView {
    WallView {
        eye: eye(),
        pa: Vec3::new(-1.5, 0.0, -1.5),
        pb: Vec3::new(1.5, 0.0, -1.5),
        pc: Vec3::new(-1.5, 3.0, -1.5),
        size: Size::new(128, 96),
    }
}

fn floor() -> WallView {
    WallView {
        eye: eye(),
        pa: Vec3::new(-1.5, 0.0, 1.5),
        pb: Vec3::new(1.5, 0.0, 1.5),
        pc: Vec3::new(-1.5, 0.0, -1.5),
        size: Size::new(128, 96),
    }
}
