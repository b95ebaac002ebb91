//! `holocave sim` end to end on the Cornell box's CAVE: a replayed session run twice gives
//! the same frame states, navigation transforms and glare figures bit for bit, every wall
//! shows every frame, and `--glare` writes a line for each eye of every frame.

use std::path::Path;

mod common;

use common::{holocave, scratch};

const FRAMES: usize = 10;

/// Runs a replayed `sim` of [`FRAMES`] frames into `out` (light field `vlf`, baked there
/// when missing); its stdout.
fn sim(out: &Path, vlf: &Path) -> String {
    let o = holocave()
        .args(["sim", "--config", "configs/cave4-cornell.toml"])
        .args(["--scene", "scenes/cornell.gltf"])
        .args(["--tracker", "synthetic:walk", "--replay"])
        .args(["--frames", &FRAMES.to_string(), "--scale", "0.05"])
        .args(["--glare", "16", "--no-holodeck"])
        .arg("--vlf")
        .arg(vlf)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        o.status.success(),
        "sim failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    stdout
}

#[test]
fn a_replayed_session_gives_the_same_frames_and_glare_bit_for_bit() {
    let dir = scratch("sim-replay");
    let vlf = dir.join("cornell.vlf");
    let (a, b) = (dir.join("a"), dir.join("b"));
    let first = sim(&a, &vlf);
    sim(&b, &vlf);
    assert!(
        first.contains(&format!(
            "presented logs: identical on all 4 walls ({FRAMES} frames)"
        )),
        "{first}"
    );
    for file in ["states.bin", "navigation.csv", "glare.csv"] {
        let (x, y) = (
            std::fs::read(a.join(file)).unwrap(),
            std::fs::read(b.join(file)).unwrap(),
        );
        assert!(!x.is_empty(), "{file} is empty");
        assert!(x == y, "{file} differs between two replays of one session");
    }

    // glare.csv: its header, then the left and the right eye of every frame in order.
    let glare = std::fs::read_to_string(a.join("glare.csv")).unwrap();
    let mut lines = glare.lines();
    assert_eq!(
        lines.next(),
        Some("frame,time_ns,eye,ev_lux,dgp,ugr,sources")
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 2 * FRAMES);
    for (i, r) in rows.iter().enumerate() {
        assert_eq!(r[0], (i / 2).to_string(), "row {i}: {r:?}");
        assert_eq!(r[2], ["left", "right"][i % 2], "row {i}: {r:?}");
        let ev: f64 = r[3].parse().unwrap();
        let dgp: f64 = r[4].parse().unwrap();
        assert!(ev > 0.0 && (0.0..=1.0).contains(&dgp), "row {i}: {r:?}");
    }
}
