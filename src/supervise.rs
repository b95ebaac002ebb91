//! Supervision: the children a command starts (`sim`'s nodes and workers) started again
//! when they fail, as systemd's `Restart=on-failure` with a backoff. A child that dies
//! during the run (by a signal or with a failing exit status) is started again with the
//! same command after [`Backoff::first`], each further restart waiting twice as long up to
//! [`Backoff::cap`] while it keeps dying soon after its start, and [`Backoff::first`]
//! again once it has run [`Backoff::settled`]. A child that exits with success (it was
//! told to shut down) is left down, and nothing is restarted once the run is ending or
//! Ctrl-C was pressed. Every death is recorded — which child, when, how, when it was
//! started again — for the status line and the summary.

use std::ffi::OsString;
use std::fs::OpenOptions;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crate::launch::{Group, Watched};

/// How often the supervisor looks at its children.
const POLL: Duration = Duration::from_millis(20);

/// How long a dead child waits before it is started again.
#[derive(Clone, Copy, Debug)]
pub struct Backoff {
    /// The wait before a child's first restart, and after it had settled.
    pub first: Duration,
    /// The longest wait: a child that dies again soon after its restart waits twice as
    /// long as the last time, up to this.
    pub cap: Duration,
    /// A child that ran this long before it died had settled: it waits `first` again.
    pub settled: Duration,
}

impl Default for Backoff {
    /// 100 ms, doubling to 1 s, back to 100 ms after 10 s of running. The cap leaves a
    /// node killed again and again a second to start and present within the 2 s a wall
    /// may be dark (measured by `benches/chaos.sh`: 2.25 s with a 2 s cap).
    fn default() -> Backoff {
        Backoff {
            first: Duration::from_millis(100),
            cap: Duration::from_secs(1),
            settled: Duration::from_secs(10),
        }
    }
}

impl Backoff {
    /// The wait before restarting a child that ran `ran` before it died, its last wait
    /// having been `last` (`None`: it was never restarted).
    pub fn next(&self, last: Option<Duration>, ran: Duration) -> Duration {
        match last {
            Some(last) if ran < self.settled => (last * 2).min(self.cap),
            _ => self.first,
        }
    }
}

/// A child's command, kept so that it can be started again as it was: the program, its
/// arguments, environment and folder, its stdout and stderr appended to a log file.
pub struct Relaunch {
    program: OsString,
    args: Vec<OsString>,
    envs: Vec<(OsString, Option<OsString>)>,
    dir: Option<PathBuf>,
    log: PathBuf,
}

impl Relaunch {
    /// `command` as it is set up (its stdin, stdout and stderr aside), logging to `log`.
    pub fn new(command: &Command, log: &Path) -> Relaunch {
        Relaunch {
            program: command.get_program().to_owned(),
            args: command.get_args().map(ToOwned::to_owned).collect(),
            envs: (command.get_envs())
                .map(|(k, v)| (k.to_owned(), v.map(ToOwned::to_owned)))
                .collect(),
            dir: command.get_current_dir().map(ToOwned::to_owned),
            log: log.to_owned(),
        }
    }

    /// A fresh command starting the child: stdin from nothing, stdout and stderr appended
    /// to its log (so a restart keeps what the last run wrote).
    fn command(&self) -> std::io::Result<Command> {
        let log = (OpenOptions::new().create(true).append(true))
            .open(&self.log)
            .map_err(|e| std::io::Error::new(e.kind(), format!("{}: {e}", self.log.display())))?;
        let mut c = Command::new(&self.program);
        c.args(&self.args);
        for (key, value) in &self.envs {
            match value {
                Some(v) => c.env(key, v),
                None => c.env_remove(key),
            };
        }
        if let Some(dir) = &self.dir {
            c.current_dir(dir);
        }
        c.stdout(log.try_clone()?).stderr(log).stdin(Stdio::null());
        Ok(c)
    }

    /// Starts the child as `name`.
    fn spawn(&self, name: &str) -> std::io::Result<Watched> {
        Watched::spawn(name, &mut self.command()?)
    }
}

/// A child's death, and its restart.
#[derive(Clone, Debug)]
pub struct Death {
    /// The child's name (`node front`, `worker 0`).
    pub name: String,
    /// When the supervisor saw it dead.
    pub at: Instant,
    /// How it ended (`signal: 9 (SIGKILL)`, `exit status: 1`), or why it could not be
    /// started again.
    pub how: String,
    /// How long it had run.
    pub ran: Duration,
    /// When it was started again; `None`: it was not.
    pub restarted: Option<Instant>,
}

/// One supervised child.
struct Slot {
    name: String,
    relaunch: Relaunch,
    /// The process last started; `None` while a restart could not be started.
    child: Option<Watched>,
    /// Whether that process is running, as far as the supervisor has looked.
    up: bool,
    started: Instant,
    /// When it is to be started again, while it is down and to be restarted.
    restart_at: Option<Instant>,
    /// Its last wait before a restart; `None` before its first.
    wait: Option<Duration>,
    /// Its newest death in [`Board::deaths`], while it is down.
    death: Option<usize>,
}

/// What the supervisor does about a child that exits.
#[derive(Clone, Copy)]
enum Policy<'a> {
    /// Records a failure as a death and starts the child again after its wait.
    Restart(&'a Backoff),
    /// Records a failure as a death (supervision off).
    Record,
    /// The run is ending (its last frame sent, or Ctrl-C): an exit is no death and
    /// nothing is started again.
    Ending,
}

/// What the watching thread and the status line share.
struct Board {
    slots: Vec<Slot>,
    deaths: Vec<Death>,
}

impl Board {
    /// Looks at every child once at `now`: records the ones that died, and starts again
    /// the ones whose wait is over.
    fn tend(&mut self, now: Instant, policy: Policy) {
        for i in 0..self.slots.len() {
            self.notice_exit(i, now, policy);
            self.restart_if_due(i, now, policy);
        }
    }

    /// Whether child `i` has exited since the last look; a failure is recorded as a death
    /// (unless the run is ending) and, to be restarted, its restart scheduled.
    fn notice_exit(&mut self, i: usize, now: Instant, policy: Policy) {
        let slot = &mut self.slots[i];
        if !slot.up {
            return;
        }
        let Some(Ok(Some(status))) = slot.child.as_mut().map(|w| w.child.try_wait()) else {
            return;
        };
        slot.up = false;
        if status.success() || matches!(policy, Policy::Ending) {
            return tracing::info!("{} exited ({status})", slot.name);
        }
        let ran = now - slot.started;
        self.died(i, now, status.to_string(), ran, policy);
    }

    /// Records that child `i` died at `now` (`how`, after running `ran`) and, to be
    /// restarted, when it is started again.
    fn died(&mut self, i: usize, now: Instant, how: String, ran: Duration, policy: Policy) {
        let slot = &mut self.slots[i];
        match policy {
            Policy::Restart(backoff) => {
                let wait = backoff.next(slot.wait, ran);
                tracing::warn!(
                    "{} died ({how}) after {:.2} s; starting it again in {:.2} s",
                    slot.name,
                    ran.as_secs_f64(),
                    wait.as_secs_f64()
                );
                slot.wait = Some(wait);
                slot.restart_at = Some(now + wait);
            }
            Policy::Record | Policy::Ending => tracing::warn!(
                "{} died ({how}) after {:.2} s; not started again (supervision off)",
                slot.name,
                ran.as_secs_f64()
            ),
        }
        slot.death = Some(self.deaths.len());
        self.deaths.push(Death {
            name: slot.name.clone(),
            at: now,
            how,
            ran,
            restarted: None,
        });
    }

    /// Starts child `i` again if its wait is over; cancels its restart instead where
    /// children are no longer restarted. A start that fails is a death of its own.
    fn restart_if_due(&mut self, i: usize, now: Instant, policy: Policy) {
        let slot = &mut self.slots[i];
        let Some(at) = slot.restart_at else { return };
        if !matches!(policy, Policy::Restart(_)) {
            slot.restart_at = None;
            return;
        }
        if now < at {
            return;
        }
        slot.restart_at = None;
        match slot.relaunch.spawn(&slot.name) {
            Ok(w) => {
                tracing::info!("{} started again (pid {})", slot.name, w.child.id());
                slot.child = Some(w);
                (slot.up, slot.started) = (true, now);
                if let Some(d) = slot.death.take() {
                    self.deaths[d].restarted = Some(now);
                }
            }
            Err(e) => {
                slot.child = None;
                self.died(i, now, format!("not started: {e}"), Duration::ZERO, policy);
            }
        }
    }

    /// The status line's part: `processes 5 of 6 up (node front down), 2 restarts (node
    /// front 1, worker 0 1)`.
    fn status(&self) -> String {
        let up = self.slots.iter().filter(|s| s.up).count();
        let mut line = format!("processes {up} of {} up", self.slots.len());
        let down: Vec<&str> = (self.slots.iter())
            .filter(|s| !s.up)
            .map(|s| s.name.as_str())
            .collect();
        if !down.is_empty() {
            line += &format!(" ({} down)", down.join(", "));
        }
        let per_child: Vec<String> = (self.slots.iter())
            .map(|s| (s, self.restarts_of(&s.name)))
            .filter(|&(_, n)| n > 0)
            .map(|(s, n)| format!("{} {n}", s.name))
            .collect();
        let restarts = self.deaths.iter().filter(|d| d.restarted.is_some()).count();
        let plural = if restarts == 1 { "" } else { "s" };
        line += &format!(", {restarts} restart{plural}");
        if !per_child.is_empty() {
            line += &format!(" ({})", per_child.join(", "));
        }
        line
    }

    /// How often the child `name` was started again.
    fn restarts_of(&self, name: &str) -> usize {
        (self.deaths.iter())
            .filter(|d| d.name == name && d.restarted.is_some())
            .count()
    }
}

/// Children watched by a thread of their own, started again when they die.
pub struct Supervisor {
    board: Arc<Mutex<Board>>,
    /// Set to stop the watching thread.
    stop: Arc<AtomicBool>,
    /// Set when the run is ending: an exit is no death, and no child is started again.
    ending: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    /// When the children were first started: the origin of the summary's times.
    pub started: Instant,
}

impl Supervisor {
    /// Starts every child (an error names the one that could not be started) and watches
    /// them; `restart`: how they are started again (`None`: deaths are only recorded).
    /// Once `halt` (the process's Ctrl-C flag) is set, no child is started again.
    pub fn start(
        children: Vec<(String, Relaunch)>,
        restart: Option<Backoff>,
        halt: Arc<AtomicBool>,
    ) -> std::io::Result<Supervisor> {
        let started = Instant::now();
        let mut slots = Vec::with_capacity(children.len());
        for (name, relaunch) in children {
            slots.push(Slot {
                child: Some(relaunch.spawn(&name)?),
                name,
                relaunch,
                up: true,
                started,
                restart_at: None,
                wait: None,
                death: None,
            });
        }
        let board = Arc::new(Mutex::new(Board {
            slots,
            deaths: Vec::new(),
        }));
        let (stop, ending) = (Arc::default(), Arc::<AtomicBool>::default());
        let thread = {
            let (board, stop, ending) = (board.clone(), Arc::clone(&stop), ending.clone());
            std::thread::Builder::new()
                .name("supervisor".into())
                .spawn(move || watch(&board, restart, &stop, [&ending, &halt]))?
        };
        Ok(Supervisor {
            board,
            stop,
            ending,
            thread: Some(thread),
            started,
        })
    }

    /// The flag that says the run is ending (its last frame sent): from then on a child
    /// that exits is not started again, so none is left retrying a master that is gone.
    pub fn ending(&self) -> Arc<AtomicBool> {
        self.ending.clone()
    }

    /// Whether every child is down for good: each exited with success (it finished), or
    /// died with no restart to come (supervision off, or the run ending).
    pub fn finished(&self) -> bool {
        let board = lock(&self.board);
        (board.slots.iter()).all(|s| !s.up && s.restart_at.is_none())
    }

    /// Asks every running child to stop, as Ctrl-C asks this process: SIGTERM (where the
    /// signal reached this process alone, a supervisor's `kill` or systemd's with
    /// `KillMode=mixed`).
    pub fn terminate(&self) {
        let board = lock(&self.board);
        for w in board
            .slots
            .iter()
            .filter(|s| s.up)
            .filter_map(|s| s.child.as_ref())
        {
            let pid = nix::unistd::Pid::from_raw(w.child.id() as i32);
            if let Err(e) = nix::sys::signal::kill(pid, nix::sys::signal::Signal::SIGTERM) {
                tracing::warn!("{}: SIGTERM not sent: {e}", w.name);
            }
        }
    }

    /// A status-line part: how many children are up, which are down, how many restarts.
    pub fn status(&self) -> Box<dyn FnMut() -> String + Send> {
        let board = self.board.clone();
        Box::new(move || lock(&board).status())
    }

    /// Stops watching: the children (to wait for; dropping them kills them) and every
    /// death seen.
    pub fn stop(mut self) -> (Group, Vec<Death>) {
        self.join();
        let mut board = lock(&self.board);
        let children = (board.slots.iter_mut()).filter_map(|s| s.child.take());
        (Group(children.collect()), std::mem::take(&mut board.deaths))
    }

    /// Stops the watching thread and waits for it.
    fn join(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for Supervisor {
    /// Stops the watching thread (the children are killed as the board goes).
    fn drop(&mut self) {
        self.join();
    }
}

/// The board, even if a thread panicked while holding it (it holds no half-made state).
fn lock(board: &Mutex<Board>) -> MutexGuard<'_, Board> {
    board.lock().unwrap_or_else(|e| e.into_inner())
}

/// The watching thread: looks at the children every [`POLL`] until `stop`; restarts them
/// with `restart` (`None`: records their deaths only) until one of `halts` is set.
fn watch(
    board: &Mutex<Board>,
    restart: Option<Backoff>,
    stop: &AtomicBool,
    halts: [&AtomicBool; 2],
) {
    while !stop.load(Ordering::Relaxed) {
        let policy = match &restart {
            _ if halts.iter().any(|h| h.load(Ordering::Relaxed)) => Policy::Ending,
            Some(backoff) => Policy::Restart(backoff),
            None => Policy::Record,
        };
        lock(board).tend(Instant::now(), policy);
        std::thread::sleep(POLL);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_wait_doubles_to_the_cap_and_starts_over_once_settled() {
        let b = Backoff::default();
        let quick = Duration::from_millis(50);
        let mut wait = None;
        let waits: Vec<u64> = (0..7)
            .map(|_| {
                let w = b.next(wait, quick);
                wait = Some(w);
                w.as_millis() as u64
            })
            .collect();
        assert_eq!(waits, [100, 200, 400, 800, 1000, 1000, 1000]);
        assert_eq!(b.next(wait, b.settled), b.first);
    }
}
