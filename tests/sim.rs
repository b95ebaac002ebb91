//! `holocave sim` end to end on the Cornell box's CAVE: a replayed session run twice gives
//! the same frame states, navigation transforms and glare figures bit for bit, every wall
//! shows every frame, and `--glare` writes a line for each eye of every frame; with the
//! mirror box moving on a keyframed path, twice the same frame states again, and not those
//! of the session without it.

use std::path::Path;

mod common;

use common::{holocave, scratch};

const FRAMES: usize = 10;

/// Runs a replayed `sim` of [`FRAMES`] frames of the Cornell box into `out`, with `extra`
/// flags; its stdout.
fn sim_with(out: &Path, extra: &[&std::ffi::OsStr]) -> String {
    let o = holocave()
        .args(["sim", "--config", "configs/cave4-cornell.toml"])
        .args(["--scene", "scenes/cornell.gltf"])
        .args(["--tracker", "synthetic:walk", "--replay"])
        .args(["--frames", &FRAMES.to_string(), "--scale", "0.05"])
        .arg("--no-holodeck")
        .args(extra)
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

/// [`sim_with`] measuring glare over the light field `vlf` (baked there when missing).
fn sim(out: &Path, vlf: &Path) -> String {
    sim_with(
        out,
        &[
            "--glare".as_ref(),
            "16".as_ref(),
            "--vlf".as_ref(),
            vlf.as_os_str(),
        ],
    )
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

#[test]
fn a_moving_objects_path_is_replayed_bit_for_bit() {
    let dir = scratch("sim-objects");
    let daylight = dir.join("cornell.daylight.toml");
    std::fs::write(
        &daylight,
        "[[object]]\nname = \"box\"\nnodes = [\"mirror box\"]\n",
    )
    .unwrap();
    let path = dir.join("box.csv");
    std::fs::write(
        &path,
        "object,time_s,tx,ty,tz,qx,qy,qz,qw\n\
         box,0.0,-0.4,0.6,-0.35,0,0,0,1\n\
         box,0.3,0.2,0.6,0.1,0,0.3826834,0,0.9238795\n",
    )
    .unwrap();
    let still = [
        "--daylight".as_ref(),
        daylight.as_os_str(),
        "--no-vlf".as_ref(),
    ];
    let moving = [still.as_slice(), &["--objects".as_ref(), path.as_os_str()]].concat();
    let runs: Vec<Vec<u8>> = [
        ("a", &moving[..]),
        ("b", &moving[..]),
        ("still", &still[..]),
    ]
    .iter()
    .map(|(name, flags)| {
        let out = dir.join(name);
        let stdout = sim_with(&out, flags);
        assert!(
            stdout.contains(&format!("{FRAMES} with every wall")),
            "{stdout}"
        );
        std::fs::read(out.join("states.bin")).unwrap()
    })
    .collect();
    assert!(runs[0] == runs[1], "two replays of one path differ");
    assert!(
        runs[0] != runs[2],
        "the frame states do not carry the object's placements"
    );
}
