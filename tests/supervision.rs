//! `holocave sim` under supervision: a node or a worker SIGKILLed during the frames is
//! started again with the same command; the node's wall presents frames again, the worker
//! joins the holodeck again; the status line counts the restart and the summary lists the
//! death and the restart.
//!
//! The run is live (frames on the wall clock) and stopped by Ctrl-C once everything was
//! seen; every wait is on something observable (a presented log, a process in `/proc`, a
//! status line) with a deadline, never a fixed sleep.

use std::fs::File;
use std::os::unix::process::CommandExt;
use std::path::Path;
use std::process::{Command, ExitStatus};
use std::time::{Duration, Instant};

mod common;

use common::{Watched, holocave, scratch};

const WALLS: [&str; 4] = ["front", "left", "right", "floor"];

/// A running `sim`, stopped by Ctrl-C (SIGINT) when dropped, a failing test's included:
/// so stopped it tells its nodes to shut down, where killed it would leave them retrying.
struct Sim(Option<Watched>);

impl Sim {
    fn pid(&self) -> u32 {
        self.0.as_ref().map_or(0, |w| w.child.id())
    }

    /// Whether it has exited (and how).
    fn exited(&mut self) -> Option<ExitStatus> {
        self.0
            .as_mut()
            .and_then(|w| w.child.try_wait().ok().flatten())
    }

    /// Ctrl-C, then its exit status (`None`: it had to be killed after `limit`).
    fn stop(&mut self, limit: Duration) -> Option<ExitStatus> {
        let w = self.0.take()?;
        let _ = Command::new("kill")
            .args(["-INT", &w.child.id().to_string()])
            .status();
        w.finish(limit).0
    }

    /// Sends `signal` to sim, or with `group` to sim and every process it started (as a
    /// terminal's Ctrl-C), and waits for it to end within `common::INTERRUPT_LIMIT`: its exit
    /// status, and how long it took. Fails with what sim logged when it does not end.
    fn interrupt(&mut self, dir: &Path, signal: &str, group: bool) -> (ExitStatus, Duration) {
        let mut w = self.0.take().expect("sim running");
        let (status, took) = common::interrupt(&mut w, signal, group);
        let Some(status) = status else {
            panic!(
                "sim still running {took:?} after SIG{signal}; its stderr:\n{}",
                output(dir, "stderr.txt")
            );
        };
        (status, took)
    }
}

impl Drop for Sim {
    fn drop(&mut self) {
        self.stop(Duration::from_secs(30));
    }
}

/// Starts `sim` on the Cornell box's CAVE (tiny walls, no light field, more frames than the
/// test needs: it is stopped by Ctrl-C) with `extra` flags, its output in
/// `dir/out`, its stdout and stderr in `dir/stdout.txt` and `dir/stderr.txt`.
fn start_sim(dir: &Path, extra: &[&str]) -> Sim {
    let child = holocave()
        .args(["sim", "--config", "configs/cave4-cornell.toml"])
        .args([
            "--scene",
            "scenes/cornell.gltf",
            "--tracker",
            "synthetic:walk",
        ])
        .args(["--frames", "1000000", "--rate", "20", "--scale", "0.05"])
        .args(["--every", "1000000", "--no-vlf"])
        .args(extra)
        .arg("--out")
        .arg(dir.join("out"))
        .env("RUST_LOG", "info")
        // Its own process group, which a test's Ctrl-C reaches whole, as a terminal's.
        .process_group(0)
        .stdout(File::create(dir.join("stdout.txt")).unwrap())
        .stderr(File::create(dir.join("stderr.txt")).unwrap())
        .spawn()
        .expect("start holocave sim");
    Sim(Some(Watched::adopt("sim", child)))
}

/// The frames `wall` presented so far (none before its log exists).
fn presented(dir: &Path, wall: &str) -> Vec<u64> {
    holocave_render_node::output::read_presented(&dir.join("out").join(wall)).unwrap_or_default()
}

/// What `sim` wrote to `name` (`stdout.txt`, `stderr.txt`) so far.
fn output(dir: &Path, name: &str) -> String {
    std::fs::read_to_string(dir.join(name)).unwrap_or_default()
}

/// Waits until `cond` holds, polling; fails (with what sim logged) at `limit` or when sim
/// exits first.
fn wait_until(
    sim: &mut Sim,
    dir: &Path,
    limit: Duration,
    what: &str,
    mut cond: impl FnMut() -> bool,
) {
    let end = Instant::now() + limit;
    while !cond() {
        let why = match sim.exited() {
            Some(status) => format!("sim exited ({status})"),
            None if Instant::now() >= end => format!("timed out after {limit:?}"),
            None => {
                std::thread::sleep(Duration::from_millis(20));
                continue;
            }
        };
        let log = output(dir, "stderr.txt");
        let tail: Vec<&str> = log.lines().rev().take(12).collect();
        panic!(
            "{why} waiting for {what}; sim's stderr ends:\n{}",
            tail.into_iter().rev().collect::<Vec<_>>().join("\n")
        );
    }
}

/// The running processes `parent` started (a dead one has no command line), each with its
/// arguments after the program's, found in `/proc`.
fn children_of(parent: u32) -> Vec<(u32, Vec<String>)> {
    let Ok(entries) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    let pids = entries.filter_map(|e| e.ok()?.file_name().to_str()?.parse::<u32>().ok());
    pids.filter(|&pid| parent_of(pid) == Some(parent))
        .filter_map(|pid| {
            let cmdline = std::fs::read(format!("/proc/{pid}/cmdline")).ok()?;
            let args = (cmdline.split(|&b| b == 0).skip(1))
                .map(|a| String::from_utf8_lossy(a).into_owned())
                .collect::<Vec<_>>();
            (!args.is_empty()).then_some((pid, args))
        })
        .collect()
}

/// `pid`'s parent, from `/proc/PID/stat` (`pid (name) state ppid …`).
fn parent_of(pid: u32) -> Option<u32> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    let after_name = &stat[stat.rfind(')')? + 1..];
    after_name.split_whitespace().nth(1)?.parse().ok()
}

/// The process `parent` started for `wall`'s node (`holocave node … --wall WALL …`).
fn node_pid(parent: u32, wall: &str) -> Option<u32> {
    children_of(parent).into_iter().find_map(|(pid, args)| {
        let for_wall = args.windows(2).any(|w| w[0] == "--wall" && w[1] == wall);
        (args[0] == "node" && for_wall).then_some(pid)
    })
}

/// The `holocave worker` processes `parent` started.
fn worker_pids(parent: u32) -> Vec<u32> {
    (children_of(parent).into_iter())
        .filter(|(_, args)| args[0] == "worker")
        .map(|(pid, _)| pid)
        .collect()
}

/// Kills `pid` with SIGKILL: no goodbye, its sockets just die.
fn sigkill(pid: u32) {
    let ok = Command::new("kill")
        .args(["-KILL", &pid.to_string()])
        .status()
        .unwrap();
    assert!(ok.success(), "kill -KILL {pid}");
}

#[test]
fn a_killed_node_is_started_again_and_its_wall_presents_again() {
    let dir = scratch("sim-restart");
    let mut sim = start_sim(&dir, &["--no-holodeck"]);
    let sim_pid = sim.pid();
    wait_until(
        &mut sim,
        &dir,
        Duration::from_secs(300),
        "every wall presenting 10 frames",
        || WALLS.iter().all(|w| presented(&dir, w).len() >= 10),
    );
    let node = node_pid(sim_pid, "front").expect("sim's node for the front wall in /proc");
    sigkill(node);
    let killed = Instant::now();
    // Once the killed node is gone from sim's children (dead, it has no command line any
    // more), the front wall's log grows only if a new node presents.
    wait_until(
        &mut sim,
        &dir,
        Duration::from_secs(30),
        "the killed node gone",
        || node_pid(sim_pid, "front") != Some(node),
    );
    let before = presented(&dir, "front").len();
    wait_until(
        &mut sim,
        &dir,
        Duration::from_secs(60),
        "the front wall presenting again after its node was killed",
        || presented(&dir, "front").len() > before,
    );
    println!(
        "front: node {node} killed; the wall presented again {:.2} s later",
        killed.elapsed().as_secs_f64()
    );
    let again = node_pid(sim_pid, "front").expect("a new node for the front wall");
    assert_ne!(again, node);
    wait_until(
        &mut sim,
        &dir,
        Duration::from_secs(30),
        "a status line counting the restart",
        || output(&dir, "stderr.txt").contains("1 restart (node front 1)"),
    );
    let status = sim.stop(Duration::from_secs(60));
    let stdout = output(&dir, "stdout.txt");
    assert!(
        status.is_some_and(|s| s.code() == Some(130)),
        "sim: {status:?}\n{stdout}"
    );
    println!("{stdout}");
    assert!(
        stdout.contains("processes that died: 1, started again: 1\n"),
        "{stdout}"
    );
    let death = (stdout.lines())
        .find(|l| l.trim_start().starts_with("node front died at"))
        .unwrap_or_else(|| panic!("no line on the front node's death:\n{stdout}"));
    for part in [
        "(signal: 9 (SIGKILL)",
        "; started again at ",
        "; wall front presenting again from frame ",
    ] {
        assert!(death.contains(part), "{part:?} not in {death:?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_killed_worker_is_started_again_and_rejoins_the_holodeck() {
    let dir = scratch("sim-restart-worker");
    let mut sim = start_sim(&dir, &["--workers", "2"]);
    let sim_pid = sim.pid();
    wait_until(
        &mut sim,
        &dir,
        Duration::from_secs(300),
        "two workers in the holodeck and every wall presenting",
        || {
            output(&dir, "stderr.txt").contains("2 workers")
                && WALLS.iter().all(|w| !presented(&dir, w).is_empty())
        },
    );
    let workers = worker_pids(sim_pid);
    assert_eq!(workers.len(), 2, "sim's workers: {workers:?}");
    sigkill(workers[0]);
    // A new worker process, and the holodeck's word that it joined.
    let mut again = None;
    wait_until(
        &mut sim,
        &dir,
        Duration::from_secs(60),
        "a new worker joining the holodeck",
        || {
            again = worker_pids(sim_pid)
                .into_iter()
                .find(|p| !workers.contains(p));
            again.is_some_and(|p| output(&dir, "stderr.txt").contains(&format!("(pid {p}) joined")))
        },
    );
    wait_until(
        &mut sim,
        &dir,
        Duration::from_secs(30),
        "a status line counting the restart",
        || output(&dir, "stderr.txt").contains("1 restart (worker "),
    );
    let status = sim.stop(Duration::from_secs(60));
    let stdout = output(&dir, "stdout.txt");
    assert!(
        status.is_some_and(|s| s.code() == Some(130)),
        "sim: {status:?}\n{stdout}"
    );
    assert!(
        stdout.contains("processes that died: 1, started again: 1\n"),
        "{stdout}"
    );
    let death = (stdout.lines())
        .find(|l| l.trim_start().starts_with("worker "))
        .unwrap_or_else(|| panic!("no line on the worker's death:\n{stdout}"));
    for part in ["(signal: 9 (SIGKILL)", "; started again at "] {
        assert!(death.contains(part), "{part:?} not in {death:?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Whether process `pid` is gone (or a zombie: no command line any more).
fn gone(pid: u32) -> bool {
    std::fs::read(format!("/proc/{pid}/cmdline")).map_or(true, |c| c.is_empty())
}

/// What a `sim` that Ctrl-C ended must leave: none of its `children` running, its
/// holodeck (`dir/out/cornell.hdk`) checking clean, and a line saying it keeps it.
fn check_kept(dir: &Path, children: &[u32]) {
    let said = output(dir, "stderr.txt");
    assert!(
        said.contains("interrupted: the holodeck") && said.contains("keeps its samples"),
        "{said}"
    );
    let left: Vec<u32> = children.iter().copied().filter(|&p| !gone(p)).collect();
    assert!(left.is_empty(), "sim's processes {left:?} outlived it");
    let check = holocave()
        .args(["holodeck", "check"])
        .arg(dir.join("out").join("cornell.hdk"))
        .output()
        .unwrap();
    assert!(
        check.status.success(),
        "the kept holodeck does not check clean: {}{}",
        String::from_utf8_lossy(&check.stdout),
        String::from_utf8_lossy(&check.stderr)
    );
}

/// Ctrl-C from the terminal while the nodes start (they run, no wall presented yet)
/// reaches sim and every process it started: the nodes end before they join, so the
/// master, which waits for the walls, is stopped by sim itself. Sim ends within the limit
/// with 130 and leaves no process behind; the holodeck checks clean.
#[test]
fn ctrl_c_while_the_nodes_start_ends_sim_and_every_child() {
    let dir = scratch("sim-ctrl-c-start");
    let mut sim = start_sim(&dir, &[]);
    let sim_pid = sim.pid();
    wait_until(
        &mut sim,
        &dir,
        Duration::from_secs(120),
        "four nodes and two workers started",
        || {
            let running = children_of(sim_pid);
            running.iter().filter(|(_, a)| a[0] == "node").count() == 4 && running.len() == 6
        },
    );
    let children: Vec<u32> = children_of(sim_pid).into_iter().map(|(p, _)| p).collect();
    let shown = WALLS.iter().any(|w| !presented(&dir, w).is_empty());
    let (status, took) = sim.interrupt(&dir, "INT", true);
    println!("sim ended {took:?} after Ctrl-C during its start-up (a wall presented: {shown})");
    assert_eq!(status.code(), Some(130), "{status}");
    check_kept(&dir, &children);
    let _ = std::fs::remove_dir_all(&dir);
}

/// SIGTERM to sim alone during the frames (a supervisor's or systemd's stop): the master
/// ends its frame and tells the nodes to shut down, the holodeck commits. Sim ends within
/// the limit with 130, its summary says what the walls presented, no process is left, and
/// the holodeck checks clean.
#[test]
fn sigterm_during_the_frames_ends_sim_keeping_the_holodeck() {
    let dir = scratch("sim-sigterm-frames");
    let mut sim = start_sim(&dir, &[]);
    let sim_pid = sim.pid();
    wait_until(
        &mut sim,
        &dir,
        Duration::from_secs(300),
        "every wall presenting 3 frames",
        || WALLS.iter().all(|w| presented(&dir, w).len() >= 3),
    );
    let children: Vec<u32> = children_of(sim_pid).into_iter().map(|(p, _)| p).collect();
    let (status, took) = sim.interrupt(&dir, "TERM", false);
    println!("sim ended {took:?} after SIGTERM during the frames");
    assert_eq!(status.code(), Some(130), "{status}");
    let stdout = output(&dir, "stdout.txt");
    for part in [
        "samples added by this run",
        "(committed)",
        "presented logs: ",
    ] {
        assert!(stdout.contains(part), "{part:?} not in:\n{stdout}");
    }
    check_kept(&dir, &children);
    let _ = std::fs::remove_dir_all(&dir);
}
