//! A cluster whose four nodes show their walls in windows (`holocave node --master
//! --window`), under an Xvfb of the test's own: they present the same frames, in the same
//! order, as headless nodes do under the same master; resizing one window or closing
//! another (as a window manager would) stops neither the others nor the master; and a
//! desk user's key held or mouse dragged in a window moves the world until let go.

mod common;
mod xvfb;

use std::io::{BufReader, Read};
use std::path::Path;
use std::process::{ChildStdout, Stdio};
use std::time::{Duration, Instant};

use common::{Watched, holocave, scratch, start_master};
use holocave_master::navigation::log::Row;
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
    holocave_render_node::present::output::read_presented(&out.join(wall)).expect("a presented log")
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
    let (m, addr, stdout) = master(frames);
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
    let (last_closed, closed_logs) = check_the_closed_nodes_leave_saying_why(&mut nodes, &out);
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
    check_the_master_was_told_the_closed_walls_leave(m, stdout);
    for n in nodes.iter_mut().take(2) {
        drop(n.take());
    }
    check_all_walls_showed_the_same_frames(&out, &closed_logs);
    let _ = std::fs::remove_dir_all(&out);
}

/// The right and floor nodes (whose windows were closed) end successfully, saying why
/// they left, having presented some frames. Returns the last frame either presented and
/// the frames each presented.
fn check_the_closed_nodes_leave_saying_why(
    nodes: &mut [Option<Watched>],
    out: &Path,
) -> (u64, Vec<Vec<u64>>) {
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
        let log = presented(out, wall);
        last_closed = last_closed.max(*log.last().expect("frames before closing"));
        closed_logs.push(log);
    }
    (last_closed, closed_logs)
}

/// Stop the master (it would run 100 000 frames) and read its log: the closed node
/// told it that it leaves, so it was never declared out.
fn check_the_master_was_told_the_closed_walls_leave(
    mut m: Watched,
    mut stdout: BufReader<ChildStdout>,
) {
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
}

/// The front and left walls (still running until the master was stopped) and the closed
/// ones (`closed_logs`) presented the same frames, as far as each got.
fn check_all_walls_showed_the_same_frames(out: &Path, closed_logs: &[Vec<u64>]) {
    let logs: Vec<Vec<u64>> = ["front", "left"]
        .iter()
        .map(|w| presented(out, w))
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
    for log in closed_logs {
        assert_eq!(&log[..], &logs[0][..log.len()]);
    }
}

/// A desk user in a node's window (keys and mouse sent through XTEST as a keyboard and
/// a mouse would send them) moves the world, through the master (`--desk`): the W key
/// held walks the room ahead — along −Z, where the still head looks — by the walking
/// speed times each frame's step, in the frames after the press and only until the
/// release; then the left button dragged 100 px to the right turns it clockwise at the
/// turn rate times the drag's deflection, until the button is let go. `desk.csv` records
/// each change.
#[test]
fn a_desk_users_key_and_drag_in_a_window_move_the_world_until_released() {
    let Some(x) = Xvfb::start(640, 480) else {
        return;
    };
    let out = scratch("cluster-window-desk");
    let (master_out, node_out) = (out.join("master"), out.join("nodes"));
    let (m, addr, mut stdout) = desk_master(&master_out);
    let node = desk_node(&addr, &node_out, &x);
    let inputs = press_w_then_drag(&x, &node_out);
    let (status, _, err) = m.finish(Duration::from_secs(120));
    assert!(status.is_some_and(|s| s.success()), "master failed: {err}");
    let mut summary = String::new();
    stdout.read_to_string(&mut summary).unwrap();
    let (status, nout, nerr) = node.finish(Duration::from_secs(30));
    assert!(
        status.is_some_and(|s| s.success()),
        "node failed:\n{nout}\n{nerr}"
    );

    let desk = std::fs::read_to_string(master_out.join("desk.csv")).expect("desk.csv");
    let nav = std::fs::read_to_string(master_out.join("navigation.csv")).expect("navigation.csv");
    let rows = holocave_master::navigation::log::read(&nav).expect("navigation.csv reads back");
    let DeskInputs {
        pressed_after,
        released_after,
        dragged_after,
        let_go_after,
    } = inputs;
    println!(
        "{summary}\ndesk.csv:\n{desk}\nW pressed after frame {pressed_after}, released after \
         {released_after}; dragged after {dragged_after}, let go after {let_go_after}"
    );
    let (walked, turned) = check_each_step_walks_or_turns(&rows);
    println!("walked in frames {walked:?}, turned in {turned:?}");
    let final_frame = rows.last().expect("rows").frame;
    check_the_motion_follows_its_input(&walked, &turned, &inputs, final_frame);
    assert!(
        desk.lines().filter(|l| l.starts_with("axes,")).count() >= 4,
        "desk.csv holds no press, release, drag and let-go:\n{desk}"
    );
    let _ = std::fs::remove_dir_all(&out);
}

/// The desk test's cave: one wall, `screen`.
const DESK: &str = "configs/desk.toml";
// The navigation's defaults: m/s, rad/s, the axes' dead zone; the drag's full
// deflection (render-node's `desk::DRAG_FULL`, px).
const WALK_SPEED: f64 = 1.4;
const TURN_RATE: f64 = std::f64::consts::PI / 4.0;
const DEAD_ZONE: f64 = 0.1;
const DRAG_FULL: f64 = 200.0;
/// How far the desk test drags the mouse to the right, px.
const DRAG: i16 = 100;
/// The W key's keysym.
const KEY_W: u32 = 0x77;
/// The desk node's window.
const WINDOW: &str = "holocave screen";

/// The frames after which the desk test gave and took back each input.
struct DeskInputs {
    pressed_after: u64,
    released_after: u64,
    dragged_after: u64,
    let_go_after: u64,
}

/// A master for the desk cave taking a desk user's input (`--desk`) for 200 frames,
/// writing its logs to `out`.
fn desk_master(out: &Path) -> (Watched, String, BufReader<ChildStdout>) {
    let mut c = holocave();
    c.args(["master", "--config", DESK, "--listen", "127.0.0.1:0"])
        .args(["--rate", RATE, "--dead-node-ms", DEAD_NODE_MS])
        .args(["--frames", "200", "--wait-for-walls", "60", "--desk"])
        .arg("--out")
        .arg(out)
        .env("HOLOCAVE_SECRET", SECRET)
        .env("RUST_LOG", "info");
    start_master(c)
}

/// The desk cave's screen node in a window on `x`, writing its presented log under `out`.
fn desk_node(addr: &str, out: &Path, x: &Xvfb) -> Watched {
    let mut c = holocave();
    c.args(["node", "--master", addr, "--wall", "screen"])
        .args(["--config", DESK, "--scene", SCENE, "--size", "32x24"])
        .args(["--samples", "48", "--every", "1000000", "--window"])
        .arg("--out")
        .arg(out)
        .env("HOLOCAVE_SECRET", SECRET)
        .env("RAYON_NUM_THREADS", "1")
        .env("RUST_LOG", "info")
        .env("DISPLAY", &x.display)
        .env("WINIT_X11_SCALE_FACTOR", "1")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .stdin(Stdio::null());
    Watched::adopt("node", c.spawn().expect("start holocave node"))
}

/// After 20 frames, W held in the window for 10 frames and released, then the left
/// button dragged `DRAG` px right for 10 frames and let go, 10 frames after each.
fn press_w_then_drag(x: &Xvfb, node_out: &Path) -> DeskInputs {
    let last = || *presented(node_out, "screen").last().unwrap_or(&0);
    let ten_more = |what: &str| {
        let from = last();
        wait_until(Duration::from_secs(60), what, || last() >= from + 10);
    };
    wait_until(Duration::from_secs(120), "20 frames presented", || {
        last() >= 20
    });
    let wm = WindowManager::connect(x);
    let pressed_after = last();
    wm.key(WINDOW, KEY_W, true);
    ten_more("10 frames with W held");
    let released_after = last();
    wm.key(WINDOW, KEY_W, false);
    ten_more("10 frames after W's release");
    wm.pointer(WINDOW, 10, 10);
    wm.button(1, true);
    let dragged_after = last();
    wm.pointer(WINDOW, 10 + DRAG, 10);
    ten_more("10 frames dragging");
    let let_go_after = last();
    wm.button(1, false);
    ten_more("10 frames after the drag");
    DeskInputs {
        pressed_after,
        released_after,
        dragged_after,
        let_go_after,
    }
}

/// Each frame's step: none, the walk's (a translation), or the turn's (a rotation about
/// +Y; it moves the room about the head, so the translation changes too). Returns the
/// frames that walked and those that turned.
fn check_each_step_walks_or_turns(rows: &[Row]) -> (Vec<u64>, Vec<u64>) {
    let deflection = f64::from(DRAG) / DRAG_FULL;
    let turn_speed = TURN_RATE * (deflection - DEAD_ZONE) / (1.0 - DEAD_ZONE);
    let (mut walked, mut turned) = (Vec::new(), Vec::new());
    for w in rows.windows(2) {
        let (a, b) = (&w[0], &w[1]);
        let d: Vec<f64> = (0..3)
            .map(|k| b.translation[k] - a.translation[k])
            .collect();
        let dt = (b.time_ns - a.time_ns) as f64 * 1e-9;
        let q = |r: [f64; 4]| glam::DQuat::from_array(r);
        let step = q(b.rotation) * q(a.rotation).inverse();
        let step = if step.w < 0.0 { -step } else { step };
        let (axis, angle) = step.to_axis_angle();
        if b.rotation != a.rotation {
            // Quaternions of unit length to 1e-15 and a product of two: the angle to a
            // few 1e-15 rad at step sizes of 1e-2.
            let expected = -turn_speed * dt;
            assert!(
                (angle * axis.y - expected).abs() < 1e-9 && axis.x.abs() + axis.z.abs() < 1e-9,
                "frame {}: the room turned by {angle} rad about {axis} in {dt} s, not \
                 {expected} about +Y",
                b.frame
            );
            turned.push(b.frame);
        } else if d.iter().any(|&c| c != 0.0) {
            // The translations are sums of steps of f64s near 1 m: 1e-12 m holds their
            // rounding many times over.
            let expected = [0.0, 0.0, -WALK_SPEED * dt];
            assert!(
                d.iter().zip(expected).all(|(a, b)| (a - b).abs() < 1e-12),
                "frame {}: the room moved by {d:?} in {dt} s, not a walk's {expected:?}",
                b.frame
            );
            walked.push(b.frame);
        }
    }
    (walked, turned)
}

/// Causality: no step before its input was given, and none stopped before it was taken
/// back (frame `released_after`'s state was made before the release). How many frames
/// the input takes to reach the master depends on the machine; that the motion stops
/// at all is what a stuck key breaks (it did: X's auto-repeat counted as presses kept
/// W down after its release).
fn check_the_motion_follows_its_input(
    walked: &[u64],
    turned: &[u64],
    inputs: &DeskInputs,
    final_frame: u64,
) {
    for (what, frames, given, taken_back) in [
        ("walk", walked, inputs.pressed_after, inputs.released_after),
        ("turn", turned, inputs.dragged_after, inputs.let_go_after),
    ] {
        let (&first, &end) = (
            frames
                .first()
                .unwrap_or_else(|| panic!("held for 10 frames, no {what}")),
            frames.last().unwrap(),
        );
        assert_eq!(
            *frames,
            (first..=end).collect::<Vec<_>>(),
            "the {what} stopped and started again with one input"
        );
        assert!(
            first > given,
            "the {what} began in frame {first}, before its input (after frame {given})"
        );
        assert!(
            end >= taken_back.min(first),
            "the {what} ended in frame {end}, before its input was taken back (after frame \
             {taken_back})"
        );
        assert!(
            end < final_frame,
            "the {what} went on to the last frame ({final_frame}), its input taken back \
             after frame {taken_back}"
        );
    }
}
