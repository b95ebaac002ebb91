//! Navigation through the binary: `holocave master --replay` over the scripted walk of the
//! breakfast room (`tests/data/breakfast-walk.csv`, made by the command in
//! `docs/usage/navigation.md`) writes the same `navigation.csv` twice, walks at the
//! configured speed, and refuses a walk log with a garbage row, naming the row.

use std::path::{Path, PathBuf};
use std::time::Duration;

mod common;

use common::{holocave, require, root, scratch, start_master};

const WALK: &str = "tests/data/breakfast-walk.csv";
const RATE: f64 = 120.0;
const FRAMES: u64 = 240;

/// The breakfast room and its config, or the project's room (same CAVE) where the shared
/// scenes are absent.
fn scene() -> (PathBuf, &'static str) {
    match require::shared_or(
        "scenes/breakfast_room/BreakfastRoom.gltf",
        "walking through scenes/room.gltf instead",
    ) {
        Some(p) => (p, "configs/cave4-breakfast.toml"),
        None => (root().join("scenes/room.gltf"), "configs/cave4-room.toml"),
    }
}

/// Runs the master on `walk` for [`FRAMES`] replayed frames with its output in `out`; its
/// exit status and stderr.
fn master(walk: &Path, out: &Path) -> (bool, String) {
    let (scene, config) = scene();
    let mut c = holocave();
    c.args(["master", "--config", config, "--listen", "127.0.0.1:0"])
        .args(["--rate", &RATE.to_string(), "--replay"])
        .args(["--frames", &FRAMES.to_string()])
        .arg("--tracker")
        .arg(format!("file:{}", walk.display()))
        .arg("--scene")
        .arg(scene)
        .arg("--out")
        .arg(out)
        .env("HOLOCAVE_SECRET", "navigation-test-secret");
    let (m, _, _stdout) = start_master(c);
    let (status, _, err) = m.finish(Duration::from_secs(120));
    (status.is_some_and(|s| s.success()), err)
}

fn rows(csv: &[u8]) -> Vec<Vec<f64>> {
    let text = std::str::from_utf8(csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("frame,time_ns,tx,ty,tz,qx,qy,qz,qw"));
    lines
        .map(|l| l.split(',').map(|f| f.parse().unwrap()).collect())
        .collect()
}

#[test]
fn a_replayed_walk_gives_the_same_navigation_csv_bit_for_bit_at_the_walking_speed() {
    let dir = scratch("navigation-replay");
    let walk = root().join(WALK);
    let run = |name: &str| {
        let out = dir.join(name);
        let (ok, err) = master(&walk, &out);
        assert!(ok, "{err}");
        std::fs::read(out.join("navigation.csv")).unwrap()
    };
    let (a, b) = (run("a"), run("b"));
    assert!(a == b, "two replays of one walk log differ");
    let rows = rows(&a);
    assert_eq!(rows.len() as u64, FRAMES, "one row per frame");
    // The replay clock: frame k at k whole periods (ns).
    let period_ns = Duration::from_secs_f64(1.0 / RATE).as_nanos() as f64;
    for (k, r) in rows.iter().enumerate() {
        assert_eq!(r[0] as usize, k);
        assert_eq!(r[1], k as f64 * period_ns, "frame {k}'s time");
    }
    // The walk's first step: 1 s straight ahead (−Z) at full deflection. Over its first
    // half second nothing is in the way, so each frame moves exactly 1.4 m/s × one period
    // straight ahead (f64 rounding of a few metres: 1e-9 m) and level (the floor's
    // vertices lie within ±4e-7 m of its plane: 1e-6 m).
    let step = 1.4 * period_ns * 1e-9;
    for w in rows[1..60].windows(2) {
        let d = [w[1][2] - w[0][2], w[1][3] - w[0][3], w[1][4] - w[0][4]];
        assert!(
            (d[2] + step).abs() < 1e-9 && d[0].abs() < 1e-9 && d[1].abs() < 1e-6,
            "frame {}: moved {d:?}, expected [0, 0, {}]",
            w[1][0],
            -step
        );
    }
    // Then the joystick turns right (from 1 s): the rotation leaves the identity about −Y.
    let last = rows.last().unwrap();
    assert!(last[6] < -0.05, "turned right: qy = {}", last[6]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_walk_log_with_a_garbage_row_is_refused_naming_the_row() {
    let dir = scratch("navigation-garbage");
    let text = std::fs::read_to_string(root().join(WALK)).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    lines[11] = "axes,1500000000,0,zz";
    let broken = dir.join("broken-walk.csv");
    std::fs::write(&broken, lines.join("\n")).unwrap();
    let (ok, err) = master(&broken, &dir.join("out"));
    assert!(!ok, "a garbage row was accepted");
    assert!(
        err.contains("broken-walk.csv, line 12") && err.contains("axis 1 `zz`"),
        "the error does not name the row: {err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
