//! A master SIGKILLed in the middle of a session and started again with `--resume DIR`:
//! its nodes reconnect by themselves, every wall presents again, the frame numbers in the
//! presented logs go on after the last frame the killed master kept (none goes backwards
//! or comes twice), the state file reads back, and the resumed frames' states are the
//! ones a run without the kill sends for the same frames (a replay: the same log, the same
//! states).
//!
//! `tests/cluster_chaos.rs` kills the master, with its nodes and workers, at random under
//! `holocave supervise`.
//!
//! Every wait is on something observable (a presented log, a process's exit) with a
//! deadline, never a fixed sleep; every process is killed when the test ends or fails.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{ChildStdout, Command, Stdio};
use std::time::{Duration, Instant};

mod common;

use common::{Watched, holocave, scratch, start_master};
use holocave_master::session::{FILE_NAME, SessionState};
use holocave_protocol::cluster::{FrameState, MAX_CLUSTER_FRAME, MasterMsg};
use holocave_protocol::frame::read_frame;

const CONFIG: &str = "configs/cave4-room.toml";
const SCENE: &str = "scenes/room.gltf";
const WALLS: [&str; 4] = ["front", "left", "right", "floor"];
const SECRET: &str = "resume-test-secret";
/// Frames the resumed master sends before it ends the session.
const AFTER_RESUME: u64 = 30;

/// `holocave master` on `addr` replaying the synthetic walk at 20 Hz (a second's dead-node
/// timeout: a CI machine's two cores are shared by four nodes), every frame state
/// written to `states`, with `extra` flags; returns it and the rest of its stdout.
fn master(addr: &str, states: &Path, extra: &[&str]) -> (Watched, BufReader<ChildStdout>) {
    let mut c = holocave();
    c.args(["master", "--config", CONFIG, "--listen", addr])
        .args(["--replay", "--tracker", "synthetic:walk", "--rate", "20"])
        .args(["--dead-node-ms", "1000"])
        .arg("--states")
        .arg(states)
        .args(extra)
        .env("HOLOCAVE_SECRET", SECRET);
    let (m, listening, out) = start_master(c);
    assert_eq!(listening, addr);
    (m, out)
}

/// A render node for `wall` on the master at `addr`, presenting into `out/WALL`, its log in
/// `out/WALL.log`.
fn node(addr: &str, wall: &str, out: &Path) -> Watched {
    let child = holocave()
        .args(node_args(addr, wall, out))
        .env("HOLOCAVE_SECRET", SECRET)
        .env("RAYON_NUM_THREADS", "1")
        .env("RUST_LOG", "info")
        .stdout(Stdio::null())
        .stderr(File::create(out.join(format!("{wall}.log"))).unwrap())
        .spawn()
        .expect("start holocave node");
    Watched::adopt("node", child)
}

/// The arguments of `holocave node` for `wall` on the master at `addr`, small walls,
/// presenting into `out/WALL`.
fn node_args(addr: &str, wall: &str, out: &Path) -> Vec<std::ffi::OsString> {
    let args = ["node", "--master", addr, "--wall", wall, "--headless"]
        .into_iter()
        .chain(["--config", CONFIG, "--scene", SCENE, "--size", "32x24"])
        .chain(["--samples", "48", "--every", "1000000", "--out"]);
    (args.map(Into::into))
        .chain([out.as_os_str().to_owned()])
        .collect()
}

/// The frames `wall` presented so far (none before its log exists).
fn presented(out: &Path, wall: &str) -> Vec<u64> {
    holocave_render_node::present::output::read_presented(&out.join(wall)).unwrap_or_default()
}

/// Waits until `cond` holds, polling; fails at `limit` or when `master` exits first.
fn wait_until(master: &mut Watched, limit: Duration, what: &str, mut cond: impl FnMut() -> bool) {
    let end = Instant::now() + limit;
    while !cond() {
        if let Ok(Some(status)) = master.child.try_wait() {
            panic!("the master exited ({status}) while waiting for {what}");
        }
        assert!(
            Instant::now() < end,
            "timed out after {limit:?} waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Fails unless `wall`'s presented frame numbers only go up (none backwards, none twice).
fn assert_in_order(wall: &str, log: &[u64]) {
    if let Some(k) = log.windows(2).position(|p| p[0] >= p[1]) {
        panic!(
            "{wall} presented frame {} after frame {}: {log:?}",
            log[k + 1],
            log[k]
        );
    }
}

/// Every frame state in a `--states` log, by frame number.
fn states(path: &Path) -> BTreeMap<u64, FrameState> {
    let mut r = BufReader::new(File::open(path).unwrap());
    let mut all = BTreeMap::new();
    while !r.fill_buf().unwrap().is_empty() {
        match read_frame(&mut r, MAX_CLUSTER_FRAME) {
            Ok(MasterMsg::Frame(s)) => all.insert(s.frame, s),
            other => panic!("{}: {other:?}", path.display()),
        };
    }
    all
}

#[test]
fn a_killed_master_is_resumed_and_its_walls_present_the_frames_after_the_last_kept() {
    let dir = scratch("master-resume");
    let (session, walls) = (dir.join("session"), dir.join("walls"));
    std::fs::create_dir_all(&walls).unwrap();
    let addr = common::free_address();
    let session_flag = session.to_str().unwrap();
    let (mut first, _first_out) = master(
        &addr,
        &dir.join("states-1.bin"),
        &["--out", session_flag, "--wait-for-walls", "60"],
    );
    let nodes: Vec<Watched> = WALLS.iter().map(|w| node(&addr, w, &walls)).collect();
    wait_until(
        &mut first,
        Duration::from_secs(120),
        "every wall presenting 10 frames",
        || WALLS.iter().all(|w| presented(&walls, w).len() >= 10),
    );
    let killed = Instant::now();
    let kept = kill_keeping_state(first, &session, &walls);

    let total = kept.frame + 1 + AFTER_RESUME;
    // The same replay without a kill, alongside (it needs no nodes): the frames' reference.
    let reference = dir.join("reference.bin");
    let total_flag = total.to_string();
    let (alone, _alone_out) = master(
        &common::free_address(),
        &reference,
        &["--frames", &total_flag],
    );
    let (mut resumed, mut out) = master(
        &addr,
        &dir.join("states-2.bin"),
        &[
            "--resume",
            session_flag,
            "--frames",
            &total_flag,
            "--wait-for-walls",
            "60",
        ],
    );
    let mut line = String::new();
    out.read_line(&mut line).unwrap();
    assert_eq!(
        line.trim(),
        format!(
            "resuming the session in {session_flag} after frame {}",
            kept.frame
        )
    );
    wait_until(
        &mut resumed,
        Duration::from_secs(60),
        "every wall presenting a frame after the resume",
        || {
            WALLS.iter().all(|w| {
                let log = presented(&walls, w);
                assert_in_order(w, &log);
                log.last() > Some(&kept.frame)
            })
        },
    );
    println!(
        "master killed after frame {}; every wall presenting again {:.2} s later (the new \
         master's start included)",
        kept.frame,
        killed.elapsed().as_secs_f64()
    );
    let (status, _, err) = resumed.finish(Duration::from_secs(120));
    assert!(status.is_some_and(|s| s.success()), "resumed master: {err}");
    for (w, n) in WALLS.iter().zip(nodes) {
        let (status, _, _) = n.finish(Duration::from_secs(30));
        let log = std::fs::read_to_string(walls.join(format!("{w}.log"))).unwrap_or_default();
        assert!(
            status.is_some_and(|s| s.success()),
            "{w}'s node: {status:?}\n{log}"
        );
    }

    let logs: Vec<Vec<u64>> = WALLS.iter().map(|w| presented(&walls, w)).collect();
    let after: Vec<u64> = (kept.frame + 1..total).collect();
    for (w, log) in WALLS.iter().zip(&logs) {
        assert_in_order(w, log);
        let resumed_frames: Vec<u64> = log.iter().copied().filter(|&f| f > kept.frame).collect();
        assert_eq!(resumed_frames, after, "{w}: the frames after the resume");
    }
    let end = SessionState::read(&session.join(FILE_NAME)).unwrap();
    assert_eq!(end.frame, total - 1, "the state after the resumed run");

    assert_replayed_alike(alone, &dir.join("states-2.bin"), &reference, &after);
    let _ = std::fs::remove_dir_all(&dir);
}

/// SIGKILLs `master` (no goodbye to the nodes, no summary, no flush) and reads the state it
/// kept in `session`: whatever a wall (presenting into `walls`) showed, now or from a Swap
/// still on its way, the state reached.
fn kill_keeping_state(mut master: Watched, session: &Path, walls: &Path) -> SessionState {
    master.child.kill().unwrap();
    master.child.wait().unwrap();
    let kept = SessionState::read(&session.join(FILE_NAME))
        .unwrap_or_else(|e| panic!("the killed master's state: {e}"));
    for w in WALLS {
        let last = presented(walls, w).last().copied().unwrap();
        assert!(
            last <= kept.frame,
            "{w} presented {last}, the state kept {}",
            kept.frame
        );
    }
    kept
}

/// The resumed master's frame states (`resumed`, frames `after`) are those of the
/// uninterrupted replay `alone` wrote to `reference`, bit for bit.
fn assert_replayed_alike(alone: Watched, resumed: &Path, reference: &Path, after: &[u64]) {
    let (status, _, err) = alone.finish(Duration::from_secs(120));
    assert!(
        status.is_some_and(|s| s.success()),
        "the reference run: {err}"
    );
    let (got, want) = (states(resumed), states(reference));
    assert_eq!(got.keys().copied().collect::<Vec<_>>(), after);
    for (frame, state) in &got {
        assert!(
            state == &want[frame],
            "frame {frame}: the resumed state differs"
        );
    }
}

/// A state file cut short (a disk that filled, a file copied in half) is refused with its
/// name and the problem, and the master starts nothing.
#[test]
fn a_truncated_state_file_is_refused_by_name() {
    let dir = scratch("master-resume-bad");
    let session = dir.join("session");
    std::fs::create_dir_all(&session).unwrap();
    std::fs::write(session.join(FILE_NAME), "{\"version\": 1, \"frame\": 4").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_holocave"))
        .current_dir(common::root())
        .args(["master", "--config", CONFIG, "--listen", "127.0.0.1:0"])
        .arg("--resume")
        .arg(&session)
        .env("HOLOCAVE_SECRET", SECRET)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains(&session.join(FILE_NAME).display().to_string())
            && err.contains("truncated")
            && !err.contains("panicked"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
