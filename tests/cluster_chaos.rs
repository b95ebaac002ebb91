//! A chaos campaign on a cluster of separate processes, every one under `holocave
//! supervise` as on a real cluster's hosts (`docs/usage/supervise.md`): a master hosting
//! the holodeck with `--session DIR`, two holodeck workers and a node per wall. Random
//! processes, the master among them, are SIGKILLed one after another (ten in CI;
//! `HOLOCAVE_CHAOS_KILLS` sets how many, `benches/chaos.sh` a hundred), and nobody restarts
//! anything by hand. After every kill:
//!
//! - the process is back: a node's wall presents again, a new worker joins the holodeck,
//!   a new master goes on with the session from its state and every wall presents frames
//!   after the last one it kept;
//! - all four walls present the same frame again (frame lock);
//!
//! and at the end:
//!
//! - no wall's frame numbers ever went back or came twice;
//! - every frame state the masters sent is the one a run without kills sends for that frame
//!   (a replay: the same log, the same states);
//! - the holodeck checks clean and still holds every sample it had committed before each
//!   master's death; within a master's life its sample count never went backwards;
//! - the session's state file reads back.
//!
//! A node restarted while the workers are stopped (SIGSTOP) draws samples from the
//! holodeck in its first frames: the stored ones, as nothing else traces then.
//!
//! Every wait is on something observable (a presented log, a log line, a process in
//! `/proc`) with a deadline, never a fixed sleep; every process is stopped when the test
//! ends or fails. The recovery times are printed (the 2 s and 5 s goals are the campaign's
//! figures, not a test's).

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

mod common;

use common::{Watched, children_of, holocave, scratch, sigkill};
use holocave_master::session::{FILE_NAME, SessionState};
use holocave_protocol::cluster::{FrameState, MAX_CLUSTER_FRAME, MasterMsg};
use holocave_protocol::frame::read_frame;

const CONFIG: &str = "configs/cave4-cornell.toml";
const SCENE: &str = "scenes/cornell.gltf";
const WALLS: [&str; 4] = ["front", "left", "right", "floor"];
const WORKERS: usize = 2;
const SECRET: &str = "cluster-chaos-secret";
/// Longest wait for any one thing the campaign waits for.
const LIMIT: Duration = Duration::from_secs(90);

/// A process of the campaign: a wall's node, a worker or the master.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Target {
    Node(usize),
    Worker(usize),
    Master,
}

impl Target {
    fn name(self) -> String {
        match self {
            Target::Node(k) => format!("node {}", WALLS[k]),
            Target::Worker(_) => "worker".to_owned(),
            Target::Master => "master".to_owned(),
        }
    }
}

/// The processes a campaign of `kills` kills in turn: a fixed pseudo-random sequence
/// (xorshift, seeded) over the four nodes, the two workers and the master, the same on
/// every run; the master is among them at least once.
fn chaos_targets(kills: usize) -> Vec<Target> {
    let mut x: u64 = 0xc1a0_5c4a_05ee;
    let mut targets: Vec<Target> = (0..kills)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            match (x % 7) as usize {
                k if k < WALLS.len() => Target::Node(k),
                k if k < WALLS.len() + WORKERS => Target::Worker(k - WALLS.len()),
                _ => Target::Master,
            }
        })
        .collect();
    if !targets.contains(&Target::Master) && !targets.is_empty() {
        let middle = targets.len() / 2;
        targets[middle] = Target::Master;
    }
    targets
}

/// The cluster's processes, each under its own `holocave supervise`, and where they write.
struct Cluster {
    dir: PathBuf,
    master: Watched,
    workers: Vec<Watched>,
    nodes: Vec<Watched>,
}

impl Cluster {
    fn session(&self) -> PathBuf {
        self.dir.join("session")
    }
    fn walls(&self) -> PathBuf {
        self.dir.join("walls")
    }
    fn holodeck(&self) -> PathBuf {
        self.dir.join("cornell.hdk")
    }
    fn log(&self, name: &str) -> String {
        std::fs::read_to_string(self.dir.join(format!("{name}.log"))).unwrap_or_default()
    }
    fn presented(&self, wall: usize) -> Vec<u64> {
        holocave_render_node::present::output::read_presented(&self.walls().join(WALLS[wall]))
            .unwrap_or_default()
    }
    /// The process `target`'s supervisor runs now.
    fn pid(&self, target: Target) -> Option<u32> {
        let (supervisor, role) = match target {
            Target::Node(k) => (&self.nodes[k], "node"),
            Target::Worker(k) => (&self.workers[k], "worker"),
            Target::Master => (&self.master, "master"),
        };
        (children_of(supervisor.child.id()).into_iter())
            .find_map(|(p, a)| (a[0] == role).then_some(p))
    }
    /// Waits until `cond` holds, polling; fails at `LIMIT` with `what`, or when a
    /// supervisor exits first.
    fn wait_until(&mut self, what: &str, mut cond: impl FnMut(&Cluster) -> bool) {
        let end = Instant::now() + LIMIT;
        while !cond(self) {
            let supervisors = (self.nodes.iter_mut())
                .chain(&mut self.workers)
                .chain([&mut self.master]);
            for s in supervisors {
                if let Ok(Some(status)) = s.child.try_wait() {
                    panic!(
                        "{}'s supervisor exited ({status}) waiting for {what}",
                        s.name
                    );
                }
            }
            assert!(
                Instant::now() < end,
                "timed out after {LIMIT:?} waiting for {what}"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }
    /// The newest frame any wall presented.
    fn newest(&self) -> u64 {
        (0..WALLS.len())
            .filter_map(|k| self.presented(k).last().copied())
            .max()
            .unwrap_or(0)
    }
    /// Whether every wall presented one and the same frame after `after`.
    fn in_lock_after(&self, after: u64) -> bool {
        let logs: Vec<Vec<u64>> = (0..WALLS.len()).map(|k| self.presented(k)).collect();
        (logs[0].iter()).any(|f| *f > after && logs[1..].iter().all(|l| l.contains(f)))
    }
}

/// A test that fails leaves no process behind: each supervisor still running is stopped
/// as a service manager stops it (SIGTERM, which it passes on), then killed.
impl Drop for Cluster {
    fn drop(&mut self) {
        let all = (self.nodes.iter_mut())
            .chain(&mut self.workers)
            .chain([&mut self.master]);
        for s in all {
            if matches!(s.child.try_wait(), Ok(None)) {
                common::interrupt(s, "TERM", false);
            }
        }
    }
}

/// `holocave supervise --name NAME --log DIR/NAME.log -- holocave ARGS…`, with the
/// cluster's secret and info logging.
fn supervised(dir: &Path, name: &str, args: &[&std::ffi::OsStr]) -> Watched {
    let mut c = holocave();
    c.args(["supervise", "--name", name, "--log"])
        .arg(dir.join(format!("{name}.log")))
        .arg("--")
        .arg(env!("CARGO_BIN_EXE_holocave"))
        .args(args)
        .env("HOLOCAVE_SECRET", SECRET)
        .env("RAYON_NUM_THREADS", "1")
        .env("RUST_LOG", "info")
        .stdout(Stdio::null())
        .stderr(File::create(dir.join(format!("{name}.supervise.log"))).unwrap());
    Watched::spawn(format!("supervise {name}"), &mut c).expect("start holocave supervise")
}

/// The master's flags: the walk replayed at 20 Hz (a second's dead-node timeout: two cores
/// are shared by seven processes), `extra` besides.
fn master_args<'a>(addr: &'a str, extra: &[&'a std::ffi::OsStr]) -> Vec<&'a std::ffi::OsStr> {
    let words = ["master", "--config", CONFIG, "--listen", addr, "--replay"]
        .into_iter()
        .chain(["--tracker", "synthetic:walk", "--rate", "20"])
        .chain(["--dead-node-ms", "1000"]);
    words
        .map(std::ffi::OsStr::new)
        .chain(extra.iter().copied())
        .collect()
}

/// Starts the cluster in `dir`: the master (session in `dir/session`, every frame state
/// appended to `dir/states.bin`, the holodeck `dir/cornell.hdk` hosted at its own port),
/// the workers and the nodes (presenting into `dir/walls`), each supervised.
fn start(dir: &Path) -> Cluster {
    let (addr, holodeck_addr) = (common::free_address(), common::free_address());
    std::fs::create_dir_all(dir.join("walls")).unwrap();
    let (session, states, hdk) = (
        dir.join("session"),
        dir.join("states.bin"),
        dir.join("cornell.hdk"),
    );
    let os = std::ffi::OsStr::new;
    let extra = [
        os("--session"),
        session.as_os_str(),
        os("--states"),
        states.as_os_str(),
        os("--wait-for-walls"),
        os("60"),
        os("--holodeck"),
        hdk.as_os_str(),
        os("--scene"),
        os(SCENE),
        os("--holodeck-listen"),
        os(&holodeck_addr),
    ];
    let master = supervised(dir, "master", &master_args(&addr, &extra));
    let workers = (0..WORKERS)
        .map(|k| {
            let args = ["worker", "--server", &holodeck_addr, "--scene", SCENE].map(os);
            supervised(dir, &format!("worker-{k}"), &args)
        })
        .collect();
    let walls = dir.join("walls");
    let nodes = WALLS
        .iter()
        .map(|w| {
            let words = ["node", "--master", &addr, "--wall", w, "--headless"]
                .into_iter()
                .chain(["--config", CONFIG, "--scene", SCENE, "--size", "32x24"])
                .chain(["--samples", "48", "--every", "1000000", "--out"]);
            let args: Vec<&std::ffi::OsStr> = words.map(os).chain([walls.as_os_str()]).collect();
            supervised(&walls, w, &args)
        })
        .collect();
    Cluster {
        dir: dir.to_owned(),
        master,
        workers,
        nodes,
    }
}

/// Kills `target` with SIGKILL and waits until it is back (see [`Cluster`]'s module
/// notes) and every wall presents in lock again. How long until it was back; for the
/// master, also the salvaged copy of the holodeck taken just before the kill.
fn kill_and_await(c: &mut Cluster, target: Target, n: usize) -> (Duration, Option<PathBuf>) {
    // A process its supervisor is starting again (a worker that found no server yet).
    c.wait_until(&format!("the {} running", target.name()), |c| {
        c.pid(target).is_some()
    });
    let pid = c.pid(target).expect("the process in /proc");
    let before = c.newest();
    let mut salvage = None;
    let killed = match target {
        Target::Node(k) => {
            let shown = c.presented(k).len();
            sigkill(pid);
            let killed = Instant::now();
            let what = format!("the {} wall presenting again", WALLS[k]);
            c.wait_until(&what, |c| {
                c.presented(k).len() > shown && c.pid(target).is_some_and(|p| p != pid)
            });
            killed
        }
        Target::Worker(_) => {
            sigkill(pid);
            let killed = Instant::now();
            c.wait_until("a new worker joining the holodeck", |c| {
                (c.pid(target).filter(|&p| p != pid))
                    .is_some_and(|p| c.log("master").contains(&format!("(pid {p}) joined")))
            });
            killed
        }
        Target::Master => {
            let copy = c.dir.join(format!("salvage-{n}.hdk"));
            holodeck_command(
                &["check"],
                &c.holodeck(),
                &["--salvage".as_ref(), copy.as_os_str()],
            );
            salvage = Some(copy);
            sigkill(pid);
            let killed = Instant::now();
            c.wait_until("the killed master gone", |c| c.pid(target) != Some(pid));
            let kept = SessionState::read(&c.session().join(FILE_NAME))
                .unwrap_or_else(|e| panic!("the killed master's state: {e}"));
            assert!(
                kept.frame >= before,
                "kept frame {} < presented {before}",
                kept.frame
            );
            c.wait_until("every wall presenting after the resume", |c| {
                (0..WALLS.len()).all(|k| c.presented(k).last() > Some(&kept.frame))
            });
            killed
        }
    };
    let back = killed.elapsed();
    c.wait_until("every wall presenting the same frame", |c| {
        c.in_lock_after(before)
    });
    (back, salvage)
}

/// `holocave holodeck WORDS FILE EXTRA…`, which must succeed.
fn holodeck_command(words: &[&str], file: &Path, extra: &[&std::ffi::OsStr]) -> String {
    let out = holocave()
        .arg("holodeck")
        .args(words)
        .arg(file)
        .args(extra)
        .output()
        .unwrap();
    let said =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "holocave holodeck {words:?} {}: {said}",
        file.display()
    );
    said
}

/// Stops or resumes the worker processes (SIGSTOP, SIGCONT), leaving their supervisors be.
fn signal_workers(c: &Cluster, signal: &str) {
    for k in 0..WORKERS {
        let pid = c.pid(Target::Worker(k)).expect("a worker");
        let ok = Command::new("kill")
            .args([signal, &pid.to_string()])
            .status()
            .unwrap();
        assert!(ok.success(), "kill {signal} {pid}");
    }
}

/// With the workers stopped, a killed node's successor draws samples from the holodeck in
/// its first frames: stored ones, since nothing traces.
fn restarted_node_is_warmed_from_the_holodeck(c: &mut Cluster) {
    signal_workers(c, "-STOP");
    let front = c.walls().join("front.log");
    let said_before = std::fs::read_to_string(&front).unwrap().len();
    let (back, _) = kill_and_await(c, Target::Node(0), 0);
    let warmed = |c: &Cluster| {
        let log = std::fs::read_to_string(c.walls().join("front.log")).unwrap();
        log[said_before..].lines().find_map(|l| {
            l.split("drawing ")
                .nth(1)?
                .split(" samples from the holodeck")
                .next()?
                .parse::<u64>()
                .ok()
        })
    };
    c.wait_until("the restarted node drawing holodeck samples", |c| {
        warmed(c).is_some()
    });
    println!(
        "node front restarted with the workers stopped: back after {:.2} s, {} stored samples drawn",
        back.as_secs_f64(),
        warmed(c).unwrap()
    );
    signal_workers(c, "-CONT");
}

/// Every frame state in a `--states` log, in order.
fn states(path: &Path) -> Vec<FrameState> {
    let mut r = BufReader::new(File::open(path).unwrap());
    let mut all = Vec::new();
    while !r.fill_buf().unwrap().is_empty() {
        match read_frame(&mut r, MAX_CLUSTER_FRAME) {
            Ok(MasterMsg::Frame(s)) => all.push(s),
            other => panic!("{}: {other:?}", path.display()),
        }
    }
    all
}

/// Every state the masters sent (`dir/states.bin`, frames sent twice included: the ones a
/// killed master sent after its last kept state) equals the state an uninterrupted replay
/// sends for the same frame, bit for bit.
fn assert_replayed_alike(dir: &Path) {
    let sent = states(&dir.join("states.bin"));
    let last = sent.iter().map(|s| s.frame).max().expect("frame states");
    let reference = dir.join("reference.bin");
    let frames = (last + 1).to_string();
    let os = std::ffi::OsStr::new;
    let addr = common::free_address();
    let extra = [
        os("--frames"),
        os(&frames),
        os("--states"),
        reference.as_os_str(),
    ];
    let out = holocave()
        .args(master_args(&addr, &extra))
        .env("HOLOCAVE_SECRET", SECRET)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "the reference run: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let want: BTreeMap<u64, FrameState> = states(&reference)
        .into_iter()
        .map(|s| (s.frame, s))
        .collect();
    for s in &sent {
        assert!(
            s == &want[&s.frame],
            "frame {}: the state sent differs from the replay's",
            s.frame
        );
    }
}

/// The hosted holodeck's sample counts in the master's status lines, one list per master
/// life (a life starts at "master listening on").
fn sample_counts_per_life(log: &str) -> Vec<Vec<f64>> {
    let mut lives: Vec<Vec<f64>> = Vec::new();
    for line in log.lines() {
        if line.starts_with("master listening on") {
            lives.push(Vec::new());
        }
        let count = line
            .split("holodeck ")
            .nth(1)
            .and_then(|t| t.split(" M samples").next()?.parse().ok());
        if let (Some(n), Some(life)) = (count, lives.last_mut()) {
            life.push(n);
        }
    }
    lives
}

#[test]
fn a_supervised_cluster_heals_from_random_kills_of_every_process() {
    let dir = scratch("cluster-chaos");
    let mut c = start(&dir);
    c.wait_until(
        "two workers joined and every wall presenting 10 frames",
        |c| {
            c.log("master").matches(") joined").count() >= WORKERS
                && (0..WALLS.len()).all(|k| c.presented(k).len() >= 10)
        },
    );
    restarted_node_is_warmed_from_the_holodeck(&mut c);
    let kills = std::env::var("HOLOCAVE_CHAOS_KILLS").map_or(Ok(10), |n| n.parse());
    let targets = chaos_targets(kills.expect("HOLOCAVE_CHAOS_KILLS: a number of kills"));
    let mut salvages = Vec::new();
    for (n, &target) in targets.iter().enumerate() {
        let (back, salvage) = kill_and_await(&mut c, target, n);
        println!(
            "{} killed; back after {:.2} s",
            target.name(),
            back.as_secs_f64()
        );
        salvages.extend(salvage);
    }

    let (status, _) = common::interrupt(&mut c.master, "INT", false);
    assert_eq!(
        status.and_then(|s| s.code()),
        Some(130),
        "the master's supervisor"
    );
    // The master's goodbye ends every node and worker; their supervisors let them go.
    for s in c.nodes.drain(..).chain(c.workers.drain(..)) {
        let name = s.name.clone();
        let (status, _, _) = s.finish(Duration::from_secs(30));
        assert!(status.is_some_and(|s| s.success()), "{name}: {status:?}");
    }
    for (k, wall) in WALLS.iter().enumerate() {
        let log = c.presented(k);
        if let Some(i) = log.windows(2).position(|p| p[0] >= p[1]) {
            panic!(
                "{wall} presented frame {} after frame {}",
                log[i + 1],
                log[i]
            );
        }
    }
    assert_replayed_alike(&dir);
    common::assert_holodeck_clean(&c.holodeck());
    for copy in &salvages {
        holodeck_command(
            &["check"],
            &c.holodeck(),
            &["--holds".as_ref(), copy.as_os_str()],
        );
    }
    for (life, counts) in sample_counts_per_life(&c.log("master")).iter().enumerate() {
        assert!(
            counts.windows(2).all(|w| w[1] >= w[0]),
            "master {life}: the holodeck's samples went backwards: {counts:?}"
        );
    }
    SessionState::read(&c.session().join(FILE_NAME)).expect("the session's state");
    let _ = std::fs::remove_dir_all(&dir);
}
