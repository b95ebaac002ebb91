//! What every thread and task of a running server shares: the [`Server`] and its display
//! [`Hub`] (locked in that order), the stop flag, the wake-up of idle worker threads, the
//! clock, the commit count and first commit error, and the ray allowance that holds the
//! worker threads, if any.

use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::Instant;

use holocave_protocol::holodeck::SamplePacket;

use super::allowance::RayAllowance;
use crate::display::{EyeRequest, Hub};
use crate::file::DistanceKind;
use crate::server::{Server, ServerError, WorkerId};

pub(crate) struct State {
    server: Mutex<Server>,
    /// Subscribed displays; locked only while holding `server`.
    hub: Mutex<Hub>,
    pub(crate) wake: Condvar,
    /// Set to stop (by the caller's flag, [`super::Running::stop`] or a failed commit).
    pub(crate) stop: Arc<AtomicBool>,
    /// Open TCP connections (workers and displays).
    pub(crate) connections: AtomicUsize,
    start: Instant,
    /// The distance the holodeck stores, asked of every worker.
    pub(crate) distance: DistanceKind,
    pub(crate) commits: AtomicU64,
    /// The first commit error (the run stops on it).
    pub(crate) error: Mutex<Option<ServerError>>,
    pub(crate) scene: String,
    /// Holds the in-process worker threads to granted rays (`None`: free-running).
    pub(crate) allowance: Option<Arc<RayAllowance>>,
}

impl State {
    pub(crate) fn new(
        server: Server,
        stop: Arc<AtomicBool>,
        scene: String,
        allowance: Option<Arc<RayAllowance>>,
    ) -> Result<Self, ServerError> {
        let distance = server.cache().file().distance_kind()?;
        Ok(State {
            server: Mutex::new(server),
            hub: Mutex::new(Hub::default()),
            wake: Condvar::new(),
            stop,
            connections: AtomicUsize::new(0),
            start: Instant::now(),
            distance,
            commits: AtomicU64::new(0),
            error: Mutex::new(None),
            scene,
            allowance,
        })
    }

    /// Seconds since the start.
    pub(crate) fn now(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    pub(crate) fn stopping(&self) -> bool {
        self.stop.load(Ordering::SeqCst)
    }

    /// Stops every thread and task.
    pub(crate) fn set_stop(&self) {
        self.stop.store(true, Ordering::SeqCst);
        self.wake.notify_all();
        if let Some(a) = &self.allowance {
            a.stop();
        }
    }

    pub(crate) fn lock(&self) -> MutexGuard<'_, Server> {
        // A worker thread that panicked mid-update leaves the server as it was between
        // calls; carrying on is safer than losing the unflushed cache.
        self.server.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The server and the hub, locked in that order.
    pub(crate) fn lock_both(&self) -> (MutexGuard<'_, Server>, MutexGuard<'_, Hub>) {
        let s = self.lock();
        let h = self.hub.lock().unwrap_or_else(|p| p.into_inner());
        (s, h)
    }

    /// Stores a worker's results and hands the new samples to the displays.
    pub(crate) fn complete(&self, id: WorkerId, result: &SamplePacket) -> Result<(), ServerError> {
        let mut s = self.lock();
        let new = s.complete(id, result, self.now())?;
        if !new.is_empty() {
            let mut hub = self.hub.lock().unwrap_or_else(|p| p.into_inner());
            hub.distribute(&mut s, &new);
        }
        Ok(())
    }

    /// Serves one eye request of the display subscribed as `token`.
    pub(crate) fn request(&self, token: u64, req: EyeRequest) {
        let (mut s, mut hub) = self.lock_both();
        if let Err(e) = hub.request(&mut s, token, req) {
            tracing::warn!("display request: {e}");
        }
        if let Some(a) = &self.allowance {
            a.work_changed();
        }
        drop(hub);
        drop(s);
        // New requests may mean new work for idle worker threads.
        self.wake.notify_all();
    }

    pub(crate) fn unsubscribe(&self, token: u64) {
        let (mut s, mut hub) = self.lock_both();
        hub.unsubscribe(&mut s, token);
    }

    pub(crate) fn commit(&self) -> Result<(), ServerError> {
        let mut s = self.lock();
        let t = Instant::now();
        let seq = s.flush()?;
        tracing::info!(
            "commit {seq}: {} samples durable ({} added by this run; {:.2} s)",
            s.stats().samples,
            s.stats().added,
            t.elapsed().as_secs_f64()
        );
        self.commits.fetch_add(1, Ordering::SeqCst);
        Ok(())
    }

    /// Takes the server out once every other holder has let go.
    pub(crate) fn into_server(self) -> Server {
        self.server.into_inner().unwrap_or_else(|p| p.into_inner())
    }
}
