//! `holocave sim`'s cluster on one machine: every wall's render-node process and the
//! holodeck's worker processes under one [`Supervisor`], the holodeck hosted in this
//! process, and the master run beside a watchdog that stops them all when Ctrl-C does not
//! stop the master in time. The command (`src/cmd/sim.rs`) parses the flags, hosts the
//! holodeck and makes the master's options; this module starts, watches and stops the
//! processes ([`SimCluster`]), and says what became of them ([`deaths`], [`frames`]).

pub mod deaths;
pub mod frames;
mod node_commands;

use std::collections::BTreeSet;
use std::ffi::OsString;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use holocave_cave::{Unfolded, Wall};
use holocave_holodeck::auth::Credentials;
use holocave_master::cluster::FrameHook;
use holocave_tracer::cave_holodeck::Hosted;

use holocave_render_node::present::output::presented_logs;

use crate::launch::{Group, worker_command};
use crate::supervise::{Backoff, Death, Relaunch, Supervisor};
pub use node_commands::node_name;

/// How long the master has, after Ctrl-C, to end its frames and tell the nodes to shut
/// down: it looks at Ctrl-C only between frames, and not while it waits for the walls to
/// join or draw their first frame, so past this the processes are stopped without it.
const MASTER_GRACE: Duration = Duration::from_millis(500);

/// What `sim`'s processes are started with.
pub struct SimSpec<'a> {
    pub exe: &'a Path,
    /// The master's address, for the nodes.
    pub master: &'a str,
    /// DIR: each node writes in `DIR/<wall>/`, each worker logs to `DIR/workerN.log`.
    pub out: &'a Path,
    pub scene: &'a Path,
    /// The daylight flags every worker and node takes (`--daylight`, `--when`, `--weather`).
    pub daylight: &'a [OsString],
    pub credentials: &'a Credentials,
    /// Worker processes tracing for the holodeck (none without one).
    pub workers: usize,
    /// The walls' eye images, laid out: each node draws at its wall's place's size.
    pub unfolded: &'a Unfolded,
    /// The flags every node takes besides its wall's and those above.
    pub node_flags: Vec<OsString>,
    /// Whether a process that dies during the frames is started again.
    pub restart: bool,
}

/// The running cluster's processes and its hosted holodeck.
pub struct SimCluster {
    supervisor: Supervisor,
    hosted: Option<Hosted>,
    /// When each frame's state was made, by frame number.
    sent: Arc<Mutex<Vec<Instant>>>,
    /// Ctrl-C's flag: no child is started again once it is set, and the master then has
    /// [`MASTER_GRACE`] to stop.
    halt: Arc<AtomicBool>,
}

/// What became of the processes once the master returned.
pub struct Aftermath {
    /// The nodes and workers, to wait for.
    pub children: Group,
    /// Every death the supervisor saw.
    pub deaths: Vec<Death>,
    /// When the children were first started, and when each frame's state was made.
    pub origin: Instant,
    pub sent: Vec<Instant>,
}

impl Aftermath {
    /// Waits up to `limit` for the nodes and workers to exit (told to shut down, they end
    /// at once; one that does not is killed), then reads what each wall in `out` presented:
    /// the summary's lines on the processes that died (`restarting`: whether they were to
    /// be started again) and on the frames presented, and the frames some wall presented.
    pub fn report(
        mut self,
        limit: Duration,
        out: &Path,
        walls: &[Wall],
        restarting: bool,
    ) -> Result<(Vec<String>, BTreeSet<u64>)> {
        for problem in self.children.wait(limit) {
            tracing::warn!("{problem}");
        }
        let presented = presented_logs(out, walls)?;
        let mut lines = deaths::report(&self, restarting, &presented);
        let (frame_lines, all) = frames::presented(&presented);
        lines.extend(frame_lines);
        Ok((lines, all))
    }
}

impl SimCluster {
    /// Starts the workers (with a holodeck `hosted`) and each of `walls`' node (with its
    /// own flags) under one supervisor; once `halt` (Ctrl-C's flag) is set, none is
    /// started again.
    pub fn start(
        spec: &SimSpec,
        walls: &[(&Wall, Vec<String>)],
        hosted: Option<Hosted>,
        halt: Arc<AtomicBool>,
    ) -> Result<SimCluster> {
        let mut children = worker_children(spec, hosted.as_ref())?;
        for (wall, own) in walls {
            children.push(node_commands::child(spec, wall, own)?);
        }
        let backoff = spec.restart.then(Backoff::default);
        let supervisor = Supervisor::start(children, backoff, halt.clone())?;
        Ok(SimCluster {
            supervisor,
            hosted,
            sent: Arc::default(),
            halt,
        })
    }

    /// The master's status-line part after its own (the holodeck's, when hosted, then the
    /// processes up and down and their restarts) and its hook for every frame state, which
    /// notes when it was made and, with the last of `frames`, tells the supervisor the run
    /// is ending (no child is started again: the nodes are about to be told to shut down).
    pub fn master_hooks(&self, frames: u64) -> (Box<dyn FnMut() -> String + Send>, FrameHook) {
        let mut parts: Vec<Box<dyn FnMut() -> String + Send>> =
            (self.hosted.as_ref().map(Hosted::status))
                .into_iter()
                .chain([self.supervisor.status()])
                .collect();
        let status = Box::new(move || {
            let parts: Vec<String> = parts.iter_mut().map(|p| p()).collect();
            parts.join(" | ")
        });
        let (sent, ending) = (self.sent.clone(), self.supervisor.ending());
        let hook: FrameHook = Box::new(move |state| {
            lock(&sent).push(Instant::now());
            if state.frame + 1 >= frames {
                ending.store(true, Ordering::Relaxed);
            }
        });
        (status, hook)
    }

    /// Runs `master` beside a watchdog: once Ctrl-C's flag is set and the master has not
    /// returned within [`MASTER_GRACE`], the watchdog kills the processes, stops the
    /// holodeck (committing what it received) and calls `on_hang` (which ends the
    /// process). When the master returns, stops supervising, then the holodeck, which
    /// commits its samples and tells the workers goodbye (also when the master failed, so
    /// what the workers traced is kept).
    pub fn run_master<T>(
        self,
        on_hang: &(dyn Fn() + Sync),
        master: impl FnOnce() -> T,
    ) -> Result<(T, Aftermath)> {
        let origin = self.supervisor.started;
        let (sent, halt) = (self.sent.clone(), self.halt.clone());
        let running = Mutex::new(Some(self));
        let (out, running) = std::thread::scope(|s| {
            s.spawn(|| end_if_the_master_hangs(&running, &halt, on_hang));
            let out = master();
            (out, lock(&running).take())
        });
        let cluster = running.expect("only the watchdog takes it, and it ends the process");
        let (children, deaths) = cluster.supervisor.stop();
        if let Some(h) = cluster.hosted {
            stop_hosted(h)?;
        }
        let sent = std::mem::take(&mut *lock(&sent));
        let ended = Aftermath {
            children,
            deaths,
            origin,
            sent,
        };
        Ok((out, ended))
    }

    /// Kills the children (they wait for a master that is gone), then stops the holodeck,
    /// which commits what it received (it waits for its connections to close).
    fn kill(self) -> Result<()> {
        drop(self.supervisor.stop());
        self.hosted.map_or(Ok(()), stop_hosted)
    }
}

/// The watchdog beside the master (see [`SimCluster::run_master`]). Returns when the
/// master returned first (it took `running`).
fn end_if_the_master_hangs(
    running: &Mutex<Option<SimCluster>>,
    halt: &AtomicBool,
    on_hang: &(dyn Fn() + Sync),
) {
    let mut since = None;
    loop {
        std::thread::sleep(Duration::from_millis(20));
        let mut r = lock(running);
        if r.is_none() {
            return;
        }
        if !halt.load(Ordering::Relaxed) {
            continue;
        }
        if since.get_or_insert_with(Instant::now).elapsed() < MASTER_GRACE {
            continue;
        }
        tracing::warn!("the master did not stop: stopping the nodes, workers and holodeck");
        if let Some(Err(e)) = r.take().map(SimCluster::kill) {
            tracing::error!("{e:#}");
        }
        return on_hang();
    }
}

/// Stops a hosted holodeck (`sim`'s, or a master's), committing everything traced, and
/// says how much it holds.
pub fn stop_hosted(hosted: Hosted) -> Result<()> {
    let path = hosted.path.clone();
    let stopped = hosted.stop()?;
    println!("holodeck {}: {stopped}", path.display());
    Ok(())
}

/// `spec.workers` worker processes tracing for the holodeck `hosted` (none without one),
/// each logging to `workerN.log` (fresh each run; a restart appends).
fn worker_children(spec: &SimSpec, hosted: Option<&Hosted>) -> Result<Vec<(String, Relaunch)>> {
    let Some(h) = hosted else {
        return Ok(Vec::new());
    };
    let addr = h.addr.to_string();
    (0..spec.workers)
        .map(|i| {
            let log = spec.out.join(format!("worker{i}.log"));
            std::fs::File::create(&log).with_context(|| format!("{}", log.display()))?;
            let command =
                worker_command(spec.exe, &addr, spec.scene, spec.daylight, spec.credentials);
            Ok((format!("worker {i}"), Relaunch::new(&command, &log)))
        })
        .collect()
}

/// A lock's value, even if a thread panicked while holding it (none holds half-made state).
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}
