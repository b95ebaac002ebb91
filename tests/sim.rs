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

/// The Cornell box set in Chicago, so that it has a time of day.
const SITED: &str = "[site]\nlatitude = 41.98\nlongitude = -87.92\nelevation = 201.0\n\
                     time_zone = -6.0\nnorth = [0.0, 0.0, -1.0]\n\n\
                     [sun]\nangular_diameter_deg = 0.53\nirradiance = [600.0, 540.0, 460.0]\n";

/// Each frame's time of day in a states log, in frame order.
fn times_of_day(states: &Path) -> Vec<Option<String>> {
    use holocave_protocol::cluster::{MAX_CLUSTER_FRAME, MasterMsg};
    use holocave_protocol::frame::{FrameError, read_frame};
    let mut r = std::io::BufReader::new(std::fs::File::open(states).unwrap());
    let mut times = Vec::new();
    loop {
        match read_frame::<_, MasterMsg>(&mut r, MAX_CLUSTER_FRAME) {
            Ok(MasterMsg::Frame(f)) => times.push(f.when),
            Ok(_) => {}
            Err(FrameError::Closed) => return times,
            Err(e) => panic!("{}: {e}", states.display()),
        }
    }
}

#[test]
fn a_replayed_time_of_day_steps_at_the_same_frame_bit_for_bit() {
    let dir = scratch("sim-time");
    let daylight = dir.join("cornell.daylight.toml");
    std::fs::write(&daylight, SITED).unwrap();
    // 15:00 from the start (a log's times count from its first row), 18:00 from 0.15 s:
    // frame 5 (at 5/30 s) is the first at the new time.
    let times = dir.join("times.csv");
    std::fs::write(
        &times,
        "# unit: ns\ntime,0,2026-06-21T15:00\ntime,150000000,2026-06-21T18:00\n",
    )
    .unwrap();
    let buttons = format!("file:{}", times.display());
    let vlf = dir.join("cornell.vlf");
    let flags = [
        "--daylight".as_ref(),
        daylight.as_os_str(),
        "--when".as_ref(),
        "2026-06-21T15:00".as_ref(),
        "--buttons".as_ref(),
        buttons.as_ref(),
        "--vlf".as_ref(),
        vlf.as_os_str(),
        "--glare".as_ref(),
        "16".as_ref(),
        // The walls' relights are waited for as long as sim allows.
        "--dead-node-ms".as_ref(),
        "10000".as_ref(),
    ];
    let runs: Vec<(Vec<u8>, String)> = ["a", "b"]
        .iter()
        .map(|name| {
            let out = dir.join(name);
            let stdout = sim_with(&out, &flags);
            for wall in ["front", "left", "right", "floor"] {
                let log = std::fs::read_to_string(out.join(wall).join("node.log")).unwrap();
                assert!(
                    log.contains("lit for 2026-06-21T18:00:00 in"),
                    "the {wall} wall was not lit for the new time:\n{log}"
                );
            }
            (std::fs::read(out.join("states.bin")).unwrap(), stdout)
        })
        .collect();
    let stdout = &runs[0].1;
    assert!(
        stdout.contains("glare: 5 frames at another time of day than --when not measured"),
        "{stdout}"
    );
    assert!(runs[0].0 == runs[1].0, "two replays of one session differ");
    let (start, later) = ("2026-06-21T15:00:00", "2026-06-21T18:00:00");
    let expected: Vec<Option<String>> = (0..FRAMES)
        .map(|f| Some(if f < 5 { start } else { later }.to_string()))
        .collect();
    assert_eq!(times_of_day(&dir.join("a").join("states.bin")), expected);
}
