//! `holocave cave`: check a CAVE configuration and show its walls and frusta.

use std::path::PathBuf;

use anyhow::Result;
use clap::Subcommand;
use glam::Quat;
use holocave_cave::eye_position;
use holocave_cave::{CaveFrusta, load_cave};
use holocave_tracking::Pose;

#[derive(Subcommand)]
pub enum CaveCommand {
    /// Validate a CAVE config and print its walls and the frusta for a head at room.inside.
    Check {
        /// The CAVE config (TOML).
        config: PathBuf,
    },
}

pub fn run(cmd: CaveCommand) -> Result<()> {
    let CaveCommand::Check { config } = cmd;
    let cave = load_cave(&config)?;
    println!(
        "{}: {} walls, ipd {} m, tracking {:?}",
        config.display(),
        cave.walls.len(),
        cave.ipd,
        cave.source
    );
    println!(
        "wall      node      size m       pixels      stereo  normal              distance from inside m"
    );
    for w in &cave.walls {
        println!(
            "{:<9} {:<9} {:.2} x {:.2}  {:>4} x {:<4}  {:<6}  ({:>5.2},{:>5.2},{:>5.2})  {:.3}",
            w.name,
            w.node,
            w.width,
            w.height,
            w.pixels.width,
            w.pixels.height,
            format!("{:?}", w.stereo).to_lowercase(),
            w.normal.x,
            w.normal.y,
            w.normal.z,
            w.distance(cave.inside)
        );
    }
    println!("\nwindows (holocave node --window):");
    for w in &cave.walls {
        for (k, win) in w.windows.iter().enumerate() {
            let shown = win.window_size(w.pixels);
            println!(
                "{:<9} window {k}: {} ({shown} at the wall's pixels)",
                w.name,
                win.describe()
            );
        }
    }
    let head = Pose::new(cave.inside.as_vec3(), Quat::IDENTITY);
    let mut frusta = CaveFrusta::new(&cave);
    frusta.update(&cave, &head);
    println!("\nfrusta for a head at room.inside looking at -Z (field of view, degrees):");
    for (w, v) in cave.walls.iter().zip(&frusta.walls) {
        for (eye, f) in &v.eyes {
            let e = eye_position(&cave, &head, *eye);
            let d = w.distance(e);
            let l = w.right.dot(w.pa - e);
            let r = w.right.dot(w.pb - e);
            let b = w.up.dot(w.pa - e);
            let t = w.up.dot(w.pc - e);
            let deg = |a: f64, z: f64| (a / z).atan().to_degrees();
            println!(
                "{:<9} {:<6?} eye ({:.3}, {:.3}, {:.3})  near {:.3} m  horizontal {:.1}..{:.1}  vertical {:.1}..{:.1}",
                w.name,
                eye,
                f.eye.x,
                f.eye.y,
                f.eye.z,
                f.near,
                deg(l, d),
                deg(r, d),
                deg(b, d),
                deg(t, d)
            );
        }
    }
    print!("{}", frusta.fault_report(&cave));
    Ok(())
}
