//! A cluster whose four nodes show their walls in windows (`holocave node --master
//! --window`), under an Xvfb of the test's own: they present the same frames, in the same
//! order, as headless nodes do under the same master; and resizing one window or closing
//! another (as a window manager would) stops neither the others nor the master.

mod common;
mod xvfb;

use std::io::{BufReader, Read};
use std::path::Path;
use std::process::{ChildStdout, Stdio};
use std::time::{Duration, Instant};

use common::{Watched, holocave, scratch, start_master};
use xvfb::{WindowManager, Xvfb};

const CONFIG: &str = "configs/cave4-room.toml";
const SCENE: &str = "scenes/room.gltf";
const WALLS: [&str; 4] = ["front", "left", "right", "floor"];
const SECRET: &str = "cluster-window-test-secret";
const RATE: &str = "20";
/// Generous: a loaded CI machine must not declare a live node out.
const DEAD_NODE_MS: &str = "1000";

fn master(frames: u64) -> (Watched, String, BufReader<ChildStdout>) {
    let mut c = holocave();
    c.args(["master", "--config", CONFIG, "--listen", "127.0.0.1:0"])
        .args(["--rate", RATE, "--dead-node-ms", DEAD_NODE_MS])
        .args(["--frames", &frames.to_string(), "--wait-for-walls", "60"])
        .env("HOLOCAVE_SECRET", SECRET)
        .env("RUST_LOG", "info");
    start_master(c)
}

/// A node for `wall` writing its presented log under `out`: in a window on `x` (placed so
/// the four do not overlap), or headless.
fn node(addr: &str, wall: &str, out: &Path, x: Option<&Xvfb>) -> Watched {
    let mut c = holocave();
    c.args(["node", "--master", addr, "--wall", wall])
        .args(["--config", CONFIG, "--scene", SCENE, "--size", "32x24"])
        .args(["--samples", "48", "--every", "1000000"])
        .arg("--out")
        .arg(out)
        .env("HOLOCAVE_SECRET", SECRET)
        .env("RAYON_NUM_THREADS", "1")
        .env("RUST_LOG", "info")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .stdin(Stdio::null());
    match x {
        Some(x) => {
            let i = WALLS.iter().position(|w| *w == wall).unwrap_or(0);
            c.args(["--window", "--layout", "left"])
                .args(["--window-pos", &format!("{},0", i * 100)])
                .env("DISPLAY", &x.display)
                .env("WINIT_X11_SCALE_FACTOR", "1");
        }
        None => {
            c.arg("--headless");
        }
    }
    Watched::adopt("node", c.spawn().expect("start holocave node"))
}

fn presented(out: &Path, wall: &str) -> Vec<u64> {
    holocave_render_node::output::read_presented(&out.join(wall)).expect("a presented log")
}

/// Every wall's presented frames in a lockstep run of `frames` frames.
fn lockstep(name: &str, frames: u64, x: Option<&Xvfb>) -> Vec<Vec<u64>> {
    let out = scratch(name);
    let (m, addr, mut stdout) = master(frames);
    let nodes: Vec<Watched> = WALLS.iter().map(|w| node(&addr, w, &out, x)).collect();
    let (status, _, err) = m.finish(Duration::from_secs(180));
    assert!(
        status.is_some_and(|s| s.success()),
        "{name}: master failed: {err}"
    );
    let mut summary = String::new();
    stdout.read_to_string(&mut summary).unwrap();
    println!("{name}:\n{summary}");
    for (wall, n) in WALLS.iter().zip(nodes) {
        let (status, out, err) = n.finish(Duration::from_secs(30));
        assert!(
            status.is_some_and(|s| s.success()),
            "{name}: node {wall} failed:\n{out}\n{err}"
        );
        if x.is_some() {
            assert!(
                out.contains("window 0 ("),
                "{name}: node {wall} printed no window summary:\n{out}"
            );
        }
    }
    let logs = WALLS.iter().map(|w| presented(&out, w)).collect();
    let _ = std::fs::remove_dir_all(&out);
    logs
}

#[test]
fn windowed_nodes_present_the_frames_headless_nodes_do() {
    let Some(x) = Xvfb::start(640, 480) else {
        return;
    };
    let frames = 40;
    let headless = lockstep("cluster-headless", frames, None);
    let windowed = lockstep("cluster-windowed", frames, Some(&x));
    for (i, wall) in WALLS.iter().enumerate() {
        assert_eq!(
            windowed[i], headless[i],
            "{wall}: windowed and headless nodes presented different frames"
        );
        assert_eq!(
            windowed[i], windowed[0],
            "{wall} and {} presented different frames",
            WALLS[0]
        );
        assert_eq!(
            windowed[i],
            (0..frames).collect::<Vec<_>>(),
            "{wall}: not every frame, in order"
        );
    }
}

/// Polls until `cond` holds or `limit` passes.
fn wait_until(limit: Duration, what: &str, mut cond: impl FnMut() -> bool) {
    let end = Instant::now() + limit;
    while !cond() {
        assert!(Instant::now() < end, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn resizing_or_closing_one_window_stops_neither_the_others_nor_the_master() {
    let Some(x) = Xvfb::start(640, 480) else {
        return;
    };
    let out = scratch("cluster-window-close");
    let frames = 100_000;
    let (m, addr, mut stdout) = master(frames);
    let mut nodes: Vec<Option<Watched>> = WALLS
        .iter()
        .map(|w| Some(node(&addr, w, &out, Some(&x))))
        .collect();
    let count = |w: &str| presented(&out, w).len();
    wait_until(Duration::from_secs(120), "20 frames on every wall", || {
        WALLS.iter().all(|w| count(w) >= 20)
    });
    let wm = WindowManager::connect(&x);
    // Resize the left wall's window; close the right wall's; press Esc in the floor's.
    wm.resize("holocave left", 96, 60);
    wm.close("holocave right");
    wm.press_escape("holocave floor");
    let mut last_closed = 0;
    let mut closed_logs = Vec::new();
    for (i, wall) in [(2, "right"), (3, "floor")] {
        let n = nodes[i].take().unwrap();
        let (status, nout, nerr) = n.finish(Duration::from_secs(30));
        assert!(
            status.is_some_and(|s| s.success()),
            "the closed {wall} node failed:\n{nout}\n{nerr}"
        );
        assert!(
            nout.contains("left: its window was closed"),
            "the closed {wall} node did not say why it left:\n{nout}"
        );
        let log = presented(&out, wall);
        last_closed = last_closed.max(*log.last().expect("frames before closing"));
        closed_logs.push(log);
    }
    // The others go on: 40 more frames each after the closed walls' last.
    wait_until(
        Duration::from_secs(120),
        "40 frames after the closed walls' last",
        || {
            ["front", "left"].iter().all(|w| {
                presented(&out, w)
                    .last()
                    .is_some_and(|&f| f >= last_closed + 40)
            })
        },
    );
    // The resized window shows the wall at its new size.
    let shot = x.screenshot("holocave left").expect("a screenshot of left");
    assert_eq!(
        shot.dimensions(),
        (96, 60),
        "the left window was not resized"
    );
    assert!(
        shot.pixels().any(|p| p.0 != [0, 0, 0]),
        "the resized window is black"
    );
    // Stop the master (it would run 100 000 frames) and read its log: the closed node
    // told it that it leaves, so it was never declared out.
    let mut m = m;
    let _ = m.child.kill();
    let (_, _, log) = m.finish(Duration::from_secs(10));
    let mut said = String::new();
    let _ = stdout.read_to_string(&mut said);
    for wall in ["right", "floor"] {
        assert!(
            log.contains(&format!("(wall \"{wall}\") leaves: its window was closed")),
            "the master was not told the {wall} wall leaves:\n{log}"
        );
        assert!(
            !log.lines()
                .any(|l| l.contains(&format!("wall \"{wall}\"")) && l.contains("declared out")),
            "the closed {wall} wall was declared out instead:\n{log}"
        );
    }
    for n in nodes.iter_mut().take(2) {
        drop(n.take());
    }
    let logs: Vec<Vec<u64>> = ["front", "left"]
        .iter()
        .map(|w| presented(&out, w))
        .collect();
    // Frame lock holds among the remaining walls: each shows the frames the others show,
    // but the last one may be cut by the kill.
    let common = logs.iter().map(Vec::len).min().unwrap() - 1;
    for l in &logs {
        assert_eq!(
            &l[..common],
            &logs[0][..common],
            "the remaining walls diverged"
        );
    }
    // The closed walls presented what the others did, up to their close.
    for log in &closed_logs {
        assert_eq!(&log[..], &logs[0][..log.len()]);
    }
    let _ = std::fs::remove_dir_all(&out);
}
