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

use common::{Watched, children_of, holocave, scratch, sigkill};

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
    holocave_render_node::present::output::read_presented(&dir.join("out").join(wall))
        .unwrap_or_default()
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
    common::assert_holodeck_clean(&dir.join("out").join("cornell.hdk"));
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

/// The children a chaos campaign kills in turn: a fixed pseudo-random sequence (xorshift,
/// seeded) over the four nodes and two workers, the same on every run.
fn chaos_targets(kills: usize) -> Vec<usize> {
    let mut x: u64 = 0x5eed_c4a0_5eed;
    (0..kills)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x % 6) as usize
        })
        .collect()
}

/// The holodeck's sample counts, in millions, as sim's status lines gave them in order.
fn sample_counts(stderr: &str) -> Vec<f64> {
    (stderr.lines())
        .filter_map(|l| {
            let at = l.find("holodeck ")? + "holodeck ".len();
            l[at..].split(" M samples").next()?.parse().ok()
        })
        .collect()
}

/// Kills one of sim's children (`target`: 0–3 a wall's node, 4–5 a worker) with SIGKILL
/// and waits until it is back: a node's wall presenting a frame again, or a new worker
/// joined to the holodeck. How long that took.
fn kill_and_await(sim: &mut Sim, dir: &Path, target: usize) -> Duration {
    let sim_pid = sim.pid();
    let limit = Duration::from_secs(60);
    if let Some(wall) = WALLS.get(target) {
        let node = node_pid(sim_pid, wall).expect("the wall's node in /proc");
        sigkill(node);
        let killed = Instant::now();
        wait_until(sim, dir, limit, "the killed node gone", || {
            node_pid(sim_pid, wall) != Some(node)
        });
        let before = presented(dir, wall).len();
        let what = format!("the {wall} wall presenting again");
        wait_until(sim, dir, limit, &what, || {
            presented(dir, wall).len() > before
        });
        return killed.elapsed();
    }
    let workers = worker_pids(sim_pid);
    let victim = workers[(target - WALLS.len()) % workers.len()];
    sigkill(victim);
    let killed = Instant::now();
    wait_until(sim, dir, limit, "a new worker joining the holodeck", || {
        let joined = |p: &u32| output(dir, "stderr.txt").contains(&format!("(pid {p}) joined"));
        (worker_pids(sim_pid).iter()).any(|p| *p != victim && !workers.contains(p) && joined(p))
    });
    killed.elapsed()
}

/// A chaos campaign: SIGKILLs of sim's nodes and workers, one after another in a fixed
/// pseudo-random order, ten in CI (`HOLOCAVE_CHAOS_KILLS` sets how many:
/// `benches/chaos.sh` runs a hundred). Each comes back (its wall presents again, or a new
/// worker joins the holodeck); the walls end presenting the same frames in lock; the
/// summary counts every death and restart; the holodeck's sample count never went
/// backwards and its file checks clean after the run. The recovery times are printed;
/// a test asserts no speed (the 2 s goal is a benchmark's figure).
#[test]
fn killed_nodes_and_workers_come_back_and_lose_nothing() {
    let dir = scratch("sim-chaos");
    let mut sim = start_sim(&dir, &["--workers", "2"]);
    wait_until(
        &mut sim,
        &dir,
        Duration::from_secs(300),
        "two workers in the holodeck and every wall presenting 10 frames",
        || {
            output(&dir, "stderr.txt").contains("2 workers")
                && WALLS.iter().all(|w| presented(&dir, w).len() >= 10)
        },
    );
    let kills = std::env::var("HOLOCAVE_CHAOS_KILLS").map_or(Ok(10), |n| n.parse());
    let targets = chaos_targets(kills.expect("HOLOCAVE_CHAOS_KILLS: a number of kills"));
    let first = (WALLS.iter())
        .filter_map(|w| presented(&dir, w).last().copied())
        .max()
        .unwrap_or(0);
    for &target in &targets {
        let back = kill_and_await(&mut sim, &dir, target);
        let name = WALLS
            .get(target)
            .map_or("worker".to_string(), |w| format!("node {w}"));
        println!("{name} killed; back after {:.2} s", back.as_secs_f64());
    }
    let ends: Vec<usize> = WALLS.iter().map(|w| presented(&dir, w).len()).collect();
    wait_until(
        &mut sim,
        &dir,
        Duration::from_secs(60),
        "every wall presenting 10 more frames",
        || (WALLS.iter().zip(&ends)).all(|(w, &n)| presented(&dir, w).len() >= n + 10),
    );
    let status = sim.stop(Duration::from_secs(60));
    let stdout = output(&dir, "stdout.txt");
    assert!(
        status.is_some_and(|s| s.code() == Some(130)),
        "sim: {status:?}\n{stdout}"
    );
    let deaths = format!(
        "processes that died: {0}, started again: {0}\n",
        targets.len()
    );
    assert!(stdout.contains(&deaths), "{deaths:?} not in:\n{stdout}");
    // The walls' last frames, in frame lock: every wall presented each of the eight
    // frames up to the last that all presented (Ctrl-C may stop a wall a frame early).
    let logs: Vec<Vec<u64>> = WALLS.iter().map(|w| presented(&dir, w)).collect();
    let end = (logs.iter())
        .filter_map(|l| l.last().copied())
        .min()
        .unwrap_or(0);
    let lock: Vec<u64> = (end.saturating_sub(7)..=end).collect();
    for (wall, log) in WALLS.iter().zip(&logs) {
        let upto: Vec<u64> = log.iter().copied().filter(|&f| f <= end).collect();
        let tail = &upto[upto.len().saturating_sub(lock.len())..];
        assert_eq!(tail, &lock[..], "the {wall} wall's last frames");
        let shown = log.iter().filter(|&&f| f > first && f <= end).count();
        let frames = end.saturating_sub(first).max(1);
        println!(
            "{wall}: presented {shown} of the campaign's {frames} frames ({:.1} %)",
            100.0 * shown as f64 / frames as f64
        );
    }
    let counts = sample_counts(&output(&dir, "stderr.txt"));
    assert!(
        !counts.is_empty(),
        "no holodeck figures in sim's status lines"
    );
    assert!(
        counts.windows(2).all(|w| w[1] >= w[0]),
        "the holodeck's samples went backwards: {counts:?}"
    );
    common::assert_holodeck_clean(&dir.join("out").join("cornell.hdk"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// `holocave supervise` on a cluster's host, as `docs/usage/supervise.md` runs it: a master
/// on loopback, the front wall's node under supervision and the other walls' nodes plain.
/// The supervised node, SIGKILLed, is started again and its wall presents again; Ctrl-C to
/// the supervisor stops the node (SIGTERM) and exits 130, leaving no node behind.
#[test]
fn holocave_supervise_keeps_a_clusters_node_running() {
    const CONFIG: &str = "configs/cave4-cornell.toml";
    let dir = scratch("supervise-node");
    let out = dir.join("out");
    let mut master = holocave();
    master
        .args(["master", "--config", CONFIG, "--listen", "127.0.0.1:0"])
        .args(["--rate", "20", "--seconds", "300", "--wait-for-walls", "60"])
        .env("HOLOCAVE_SECRET", "supervise-test");
    let (_master, addr, _stdout) = common::start_master(master);
    let node = |wall: &str| {
        let mut c = holocave();
        c.args(["node", "--master", &addr, "--wall", wall, "--headless"])
            .args(["--config", CONFIG, "--scene", "scenes/cornell.gltf"])
            .args(["--size", "32x24", "--samples", "48", "--every", "1000000"])
            .arg("--out")
            .arg(&out)
            .env("HOLOCAVE_SECRET", "supervise-test")
            .env("RAYON_NUM_THREADS", "1");
        c
    };
    let mut supervised = holocave();
    supervised
        .args(["supervise", "--log"])
        .arg(dir.join("front.log"))
        .arg("--")
        .arg(env!("CARGO_BIN_EXE_holocave"))
        .args(node("front").get_args())
        .envs(node("front").get_envs().filter_map(|(k, v)| Some((k, v?))))
        .stderr(File::create(dir.join("stderr.txt")).unwrap());
    let mut sim = Sim(Some(Watched::spawn("supervise", &mut supervised).unwrap()));
    let _others: Vec<Watched> = (WALLS[1..].iter())
        .map(|w| Watched::spawn(*w, node(w).stderr(std::process::Stdio::null())).unwrap())
        .collect();
    let front = |dir: &Path| {
        holocave_render_node::present::output::read_presented(&dir.join("out").join("front"))
            .unwrap_or_default()
    };
    let limit = Duration::from_secs(120);
    wait_until(
        &mut sim,
        &dir,
        limit,
        "the front wall presenting 10 frames",
        || front(&dir).len() >= 10,
    );
    let pid = sim.pid();
    let first = node_pid(pid, "front").expect("the supervised node in /proc");
    sigkill(first);
    wait_until(&mut sim, &dir, limit, "the killed node gone", || {
        node_pid(pid, "front") != Some(first)
    });
    let before = front(&dir).len();
    wait_until(
        &mut sim,
        &dir,
        limit,
        "the front wall presenting again",
        || front(&dir).len() > before,
    );
    let again = node_pid(pid, "front").expect("the node started again");
    let status = sim.stop(Duration::from_secs(30));
    assert_eq!(
        status.and_then(|s| s.code()),
        Some(130),
        "supervise: {status:?}"
    );
    assert!(
        !Path::new(&format!("/proc/{again}")).exists(),
        "the supervised node {again} outlived its supervisor"
    );
    let said = output(&dir, "stderr.txt");
    assert!(said.contains("deaths: 1, started again: 1"), "{said}");
    let _ = std::fs::remove_dir_all(&dir);
}
