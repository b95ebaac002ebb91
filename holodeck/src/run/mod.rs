//! Running a [`Server`] with its workers and displays, each part in a module of its own:
//! [`state`] (what they share), [`threads`] (in-process worker threads), [`listener`] (the
//! TCP port, tokio; workers and displays told apart by their hello), [`worker_session`] (a
//! TCP worker), [`commits`] (the periodic commit); a TCP display's session is the display
//! service's ([`crate::display::session`]). Workers and displays may join and leave at any
//! time; the server re-assigns a lost worker's packets.
//!
//! [`start`] runs it in the background and returns a [`Running`] handle (what a render
//! node embeds); [`run`] runs it until a stop condition (what `holocave fill` does). Either
//! stops when the caller's [`RunOptions::stop`] flag is set (the binary sets it on Ctrl-C).
//! [`start_held`] starts it with its worker threads held to a [`RayAllowance`] (what
//! `holocave compare` does, to give the holodeck the same rays per frame as every method).

pub mod allowance;
pub(crate) mod commits;
pub(crate) mod display_session;
pub(crate) mod listener;
pub(crate) mod state;
pub(crate) mod threads;
pub(crate) mod worker_session;

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Weak};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

pub use allowance::{RayAllowance, Settled};
use state::State;

use crate::auth::Port;
use crate::display::{DisplayClient, DisplayTally};
use crate::server::{Server, ServerError, Stats};
use crate::worker::SampleSource;

/// How to run.
pub struct RunOptions {
    /// In-process worker threads (need `source`).
    pub threads: usize,
    pub source: Option<Arc<dyn SampleSource>>,
    /// Accept TCP workers and displays here, from peers that prove its credentials.
    pub listener: Option<Port>,
    /// The scene name sent to TCP workers in the welcome.
    pub scene: String,
    /// Commit this often.
    pub commit_every: Duration,
    /// The run stops once this is set (by the caller, e.g. on Ctrl-C); the run sets it
    /// too when it stops (asked to, or because a commit failed).
    pub stop: Arc<AtomicBool>,
}

/// Progress, passed to the stop callback about ten times a second.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    pub elapsed: Duration,
    pub stats: Stats,
    pub commits: u64,
}

/// Reads a running server's totals (see [`Running::monitor`]).
#[derive(Clone)]
pub struct Monitor(Weak<State>);

impl Monitor {
    /// The running totals; `None` once the server has stopped.
    pub fn stats(&self) -> Option<Stats> {
        self.0.upgrade().map(|st| st.lock().stats())
    }
}

/// A server running in the background (see [`start`]).
pub struct Running {
    /// `None` only once stopped.
    state: Option<Arc<State>>,
    threads: Vec<JoinHandle<()>>,
    committer: Option<JoinHandle<()>>,
    rt: Option<tokio::runtime::Runtime>,
    addr: Option<SocketAddr>,
}

impl Running {
    fn st(&self) -> &Arc<State> {
        self.state.as_ref().expect("not stopped yet")
    }

    /// A display in this process: its requests and samples go through a thread of its
    /// own, so neither call of the client ever waits for the server's lock.
    pub fn display(&self, id: u32) -> DisplayClient {
        let (tx, rx) = std::sync::mpsc::channel();
        let (token, sections) = {
            let (s, mut hub) = self.st().lock_both();
            let token = hub.subscribe(id, Box::new(move |a| tx.send(a).is_ok()));
            (token, s.cache().file().sections().to_vec())
        };
        // Weak: a display left alive does not keep the server from stopping.
        let (a, b) = (Arc::downgrade(self.st()), Arc::downgrade(self.st()));
        DisplayClient::local(
            sections,
            rx,
            move |req| {
                if let Some(st) = a.upgrade() {
                    st.request(token, req);
                }
            },
            move || {
                if let Some(st) = b.upgrade() {
                    st.unsubscribe(token);
                }
            },
        )
    }

    /// What display `id` (all its connections together) has been given so far: requests
    /// served and samples handed to it (for a TCP display: queued for writing).
    pub fn display_tally(&self, id: u32) -> DisplayTally {
        self.st().lock_both().1.tally(id)
    }

    /// Running totals.
    pub fn stats(&self) -> Stats {
        self.st().lock().stats()
    }

    /// A handle that reads the running totals from another thread (an operator's status
    /// line) without keeping the server alive.
    pub fn monitor(&self) -> Monitor {
        Monitor(Arc::downgrade(self.st()))
    }

    /// The allowance the worker threads are held to ([`start_held`]).
    pub fn allowance(&self) -> Option<Arc<RayAllowance>> {
        self.st().allowance.clone()
    }

    /// Commits so far.
    pub fn commits(&self) -> u64 {
        self.st().commits.load(Ordering::SeqCst)
    }

    /// Where TCP workers and displays connect, if listening.
    pub fn local_addr(&self) -> Option<SocketAddr> {
        self.addr
    }

    /// Whether the run is stopping (the stop flag was set, or a commit failed).
    pub fn stopping(&self) -> bool {
        self.st().stopping()
    }

    /// Stops the workers and displays, commits and returns the server.
    pub fn stop(mut self) -> Result<Server, ServerError> {
        self.halt();
        let state = self.st().clone();
        // Give connected workers and displays a moment to be told goodbye.
        let deadline = Instant::now() + Duration::from_secs(2);
        while state.connections.load(Ordering::SeqCst) > 0 && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(20));
        }
        if let Some(rt) = self.rt.take() {
            rt.shutdown_timeout(Duration::from_millis(100));
        }
        let error = state.error.lock().unwrap_or_else(|p| p.into_inner()).take();
        drop(state);
        // An in-process display may hold the state for the length of one request.
        let mut state = self.state.take().expect("not stopped yet");
        let mut server = loop {
            match Arc::try_unwrap(state) {
                Ok(st) => break st.into_server(),
                Err(st) => {
                    state = st;
                    std::thread::sleep(Duration::from_millis(5));
                }
            }
        };
        if let Some(e) = error {
            return Err(e);
        }
        let seq = server.flush()?;
        tracing::info!(
            "commit {seq}: {} samples durable ({} added by this run)",
            server.stats().samples,
            server.stats().added
        );
        Ok(server)
    }

    /// Sets the stop flag and joins the worker and commit threads.
    fn halt(&mut self) {
        if let Some(st) = &self.state {
            st.set_stop();
        }
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
        if let Some(c) = self.committer.take() {
            let _ = c.join();
        }
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        self.halt();
        if let Some(rt) = self.rt.take() {
            rt.shutdown_timeout(Duration::from_millis(100));
        }
    }
}

/// Runs until `stop` returns true or the stop flag is set, then stops the workers, commits
/// and returns the server.
pub fn run(
    server: Server,
    opts: RunOptions,
    mut stop: impl FnMut(&Progress) -> bool,
) -> Result<Server, ServerError> {
    let running = start(server, opts)?;
    let t0 = Instant::now();
    loop {
        let progress = Progress {
            elapsed: t0.elapsed(),
            stats: running.stats(),
            commits: running.commits(),
        };
        if running.stopping() || stop(&progress) {
            break;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    running.stop()
}

/// Starts the server in the background: worker threads, the TCP listener (workers and
/// displays) and a commit every `opts.commit_every`.
pub fn start(server: Server, opts: RunOptions) -> Result<Running, ServerError> {
    launch(server, opts, None)
}

/// As [`start`], with the worker threads tracing only the rays `allowance` grants (see
/// [`allowance`]); stopping the run stops the allowance.
pub fn start_held(
    server: Server,
    opts: RunOptions,
    allowance: Arc<RayAllowance>,
) -> Result<Running, ServerError> {
    launch(server, opts, Some(allowance))
}

fn launch(
    server: Server,
    opts: RunOptions,
    allowance: Option<Arc<RayAllowance>>,
) -> Result<Running, ServerError> {
    let state = Arc::new(State::new(server, opts.stop, opts.scene, allowance)?);
    let threads = match &opts.source {
        Some(source) => threads::spawn(&state, source, opts.threads),
        None => Vec::new(),
    };
    let rt = listener::runtime().map_err(|e| {
        ServerError::File(crate::FileError::Io {
            path: "tokio runtime".into(),
            source: e,
        })
    })?;
    let addr = opts
        .listener
        .and_then(|p| listener::listen(&rt, &state, p.listener, p.credentials));
    let committer = commits::spawn(&state, opts.commit_every);
    Ok(Running {
        state: Some(state),
        threads,
        committer: Some(committer),
        rt: Some(rt),
        addr,
    })
}
