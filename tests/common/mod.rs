//! What the binary's end-to-end tests share: the `holocave` command run from the checkout,
//! child processes that cannot outlive a failing test, a scratch folder per test, a master
//! started on an ephemeral port, and the standalone node on the Cornell box's front wall.

#![allow(dead_code)]

pub mod require;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{ChildStdout, Command, Stdio};

pub use holocave::launch::Watched;

/// The checkout: configs and scenes are named relative to it.
pub fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// `holocave` with the checkout as its working directory.
pub fn holocave() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_holocave"));
    c.current_dir(root());
    c
}

/// `holocave node --standalone` on the front wall of `configs/cave4-cornell.toml`, looking
/// at the Cornell box; the caller adds the view, the frames and the output.
pub fn cornell_front_node() -> Command {
    front_node(Path::new("configs/cave4-cornell.toml"))
}

/// The same with another CAVE config (relative to the checkout, or absolute).
pub fn front_node(config: &Path) -> Command {
    let mut c = holocave();
    c.args(["node", "--standalone", "--config"])
        .arg(config)
        .args(["--wall", "front", "--scene", "scenes/cornell.gltf"]);
    c
}

/// An empty folder of this test's own under the system's temporary folder.
pub fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("holocave-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Starts `master` (a `holocave master …` command listening on port 0) with its output
/// piped; returns it, the address its first line names, and the rest of its stdout.
pub fn start_master(mut master: Command) -> (Watched, String, BufReader<ChildStdout>) {
    let mut child = master
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start holocave master");
    let mut out = BufReader::new(child.stdout.take().unwrap());
    let mut line = String::new();
    out.read_line(&mut line).unwrap();
    let addr = line
        .trim()
        .strip_prefix("master listening on ")
        .unwrap_or_else(|| panic!("unexpected first line {line:?}"))
        .to_owned();
    (Watched::adopt("master", child), addr, out)
}

/// How long a command may take to end after Ctrl-C or SIGTERM. The goal is a second; this
/// leaves room for a loaded CI machine (two cores shared by the test's processes).
pub const INTERRUPT_LIMIT: std::time::Duration = std::time::Duration::from_secs(5);

/// A command started with its stdout and stderr in files (`stdout.txt`, `stderr.txt` in
/// its folder), to be interrupted mid-phase; killed if the test fails first.
pub struct Logged {
    pub child: Watched,
    dir: PathBuf,
}

impl Logged {
    /// Starts `command` with its output in `dir`.
    pub fn start(command: &mut Command, dir: &Path) -> Logged {
        let file = |name: &str| std::fs::File::create(dir.join(name)).unwrap();
        command
            .stdout(file("stdout.txt"))
            .stderr(file("stderr.txt"));
        let name = format!("{:?}", command.get_args().next().unwrap_or_default());
        Logged {
            child: Watched::spawn(name, command).expect("start holocave"),
            dir: dir.to_owned(),
        }
    }

    /// What it wrote to stdout so far.
    pub fn stdout(&self) -> String {
        std::fs::read_to_string(self.dir.join("stdout.txt")).unwrap_or_default()
    }

    /// What it wrote to stderr so far.
    pub fn stderr(&self) -> String {
        std::fs::read_to_string(self.dir.join("stderr.txt")).unwrap_or_default()
    }

    /// Waits up to `limit` until `cond` holds (polling); fails, with its output, when it
    /// exits first or the time is up.
    pub fn wait_until(
        &mut self,
        limit: std::time::Duration,
        what: &str,
        mut cond: impl FnMut(&Logged) -> bool,
    ) {
        let end = std::time::Instant::now() + limit;
        while !cond(self) {
            let why = match self.child.child.try_wait().unwrap() {
                Some(status) => format!("it exited ({status})"),
                None if std::time::Instant::now() >= end => format!("timed out after {limit:?}"),
                None => {
                    std::thread::sleep(std::time::Duration::from_millis(10));
                    continue;
                }
            };
            panic!(
                "{why} waiting for {what}\nstdout:\n{}\nstderr:\n{}",
                self.stdout(),
                self.stderr()
            );
        }
    }

    /// Waits until a line of its stdout or stderr contains `sign`.
    pub fn wait_for_line(&mut self, sign: &str) {
        let what = format!("a line with {sign:?}");
        self.wait_until(std::time::Duration::from_secs(300), &what, |l| {
            l.stdout().contains(sign) || l.stderr().contains(sign)
        });
    }

    /// Sends `signal` (`INT`, `TERM`) to it, or with `group` to its process group (as a
    /// terminal's Ctrl-C reaches every process of a job: start it with
    /// `process_group(0)`), and waits up to [`INTERRUPT_LIMIT`] for it to end; its exit
    /// status and how long it took to end. Fails when it has not ended by then.
    pub fn interrupt(
        &mut self,
        signal: &str,
        group: bool,
    ) -> (std::process::ExitStatus, std::time::Duration) {
        let (status, took) = interrupt(&mut self.child, signal, group);
        let Some(status) = status else {
            panic!(
                "still running {took:?} after SIG{signal}\nstdout:\n{}\nstderr:\n{}",
                self.stdout(),
                self.stderr()
            );
        };
        (status, took)
    }
}

/// Sends `signal` (`INT`, `TERM`) to `child`, or with `group` to its process group (see
/// [`Logged::interrupt`]), and waits up to [`INTERRUPT_LIMIT`] for it to end: its exit
/// status (`None`: still running) and how long it took to end, which is logged.
pub fn interrupt(
    child: &mut Watched,
    signal: &str,
    group: bool,
) -> (Option<std::process::ExitStatus>, std::time::Duration) {
    let pid = child.child.id();
    let target = if group {
        format!("-{pid}")
    } else {
        pid.to_string()
    };
    let sent = std::time::Instant::now();
    let ok = Command::new("kill")
        .args([&format!("-{signal}"), "--", &target])
        .status()
        .unwrap();
    assert!(ok.success(), "kill -{signal} -- {target}");
    let status = child.wait_for(INTERRUPT_LIMIT);
    let took = sent.elapsed();
    let ended = status.map_or("still running".to_owned(), |s| format!("ended ({s})"));
    eprintln!(
        "{}: {ended} {:.3} s after SIG{signal}",
        child.name,
        took.as_secs_f64()
    );
    (status, took)
}

/// Asserts that `holocave holodeck check` finds the holodeck `hdk` clean.
pub fn assert_holodeck_clean(hdk: &Path) {
    let check = holocave()
        .args(["holodeck", "check"])
        .arg(hdk)
        .output()
        .unwrap();
    assert!(
        check.status.success(),
        "the holodeck {} does not check clean: {}{}",
        hdk.display(),
        String::from_utf8_lossy(&check.stdout),
        String::from_utf8_lossy(&check.stderr)
    );
}

/// The running processes `parent` started (a dead one has no command line), each with its
/// arguments after the program's, found in `/proc`.
pub fn children_of(parent: u32) -> Vec<(u32, Vec<String>)> {
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
pub fn parent_of(pid: u32) -> Option<u32> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    let after_name = &stat[stat.rfind(')')? + 1..];
    after_name.split_whitespace().nth(1)?.parse().ok()
}

/// Kills `pid` with SIGKILL: no goodbye, its sockets just die.
pub fn sigkill(pid: u32) {
    let ok = Command::new("kill")
        .args(["-KILL", &pid.to_string()])
        .status()
        .unwrap();
    assert!(ok.success(), "kill -KILL {pid}");
}

/// A loopback address no one listens on now (a master's or a holodeck's to be, where
/// nodes and workers keep reconnecting across a restart).
pub fn free_address() -> String {
    let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    l.local_addr().unwrap().to_string()
}
