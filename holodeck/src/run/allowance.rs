//! A ray allowance: holds a running server's in-process worker threads to a ray budget
//! that someone else sets (`holocave compare` gives the holodeck the same rays per frame
//! as every other method).
//!
//! The holder [`grant`](RayAllowance::grant)s rays; a worker thread
//! [`take`](RayAllowance::take)s part of what is left before tracing that many rays of its
//! packet (blocking while nothing is left) and reports them [`traced`](RayAllowance::traced)
//! afterwards, so the threads never trace a ray that was not granted. The holder then
//! [`settle`](RayAllowance::settle)s: waits until every granted ray has been traced, or
//! until no thread has anything left to trace (every one asked the server for work since
//! the work last changed, and got none), in which case what is left is withdrawn — an
//! allowance is spent when it is given or not at all, never saved up. [`stop`]
//! (RayAllowance::stop) (the run's stop does it) wakes every thread and holder that waits.
//!
//! TCP workers are not held: only the server's own threads take from the allowance.

use std::sync::{Condvar, Mutex, MutexGuard};

/// Rays granted, taken and traced so far (see the module notes).
#[derive(Default)]
pub struct RayAllowance {
    inner: Mutex<Inner>,
    changed: Condvar,
}

#[derive(Default)]
struct Inner {
    granted: u64,
    taken: u64,
    traced: u64,
    withdrawn: u64,
    /// Traced when the holder last settled.
    settled: u64,
    /// Per registered worker thread: whether it found no work since the work last changed
    /// (`None`: the slot's thread has left).
    idle: Vec<Option<bool>>,
    stopped: bool,
    /// Threads blocked in `take` or `settle` (for tests).
    waiting: usize,
}

impl Inner {
    /// Every worker thread is out of work (none registered counts: nothing can trace).
    fn starved(&self) -> bool {
        self.idle.iter().flatten().all(|&i| i) && self.traced == self.taken
    }

    /// Whether [`RayAllowance::settle`] may return.
    fn settled(&self) -> bool {
        self.stopped || self.traced == self.granted || self.starved()
    }
}

/// What one [`RayAllowance::settle`] found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Settled {
    /// Rays traced since the previous settle.
    pub traced: u64,
    /// Rays granted and not traced because the threads had nothing to trace (now
    /// withdrawn), or because the run stopped.
    pub withdrawn: u64,
}

/// Totals since the allowance was made.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Totals {
    pub granted: u64,
    pub taken: u64,
    pub traced: u64,
    pub withdrawn: u64,
}

impl RayAllowance {
    pub fn new() -> Self {
        Self::default()
    }

    fn lock(&self) -> MutexGuard<'_, Inner> {
        // Every update is a few additions; a panic cannot leave one half done.
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn wait<'a>(&self, mut g: MutexGuard<'a, Inner>) -> MutexGuard<'a, Inner> {
        g.waiting += 1;
        let mut g = self.changed.wait(g).unwrap_or_else(|p| p.into_inner());
        g.waiting -= 1;
        g
    }

    /// Adds `rays` to what the threads may trace and wakes those waiting for it.
    pub fn grant(&self, rays: u64) {
        self.lock().granted += rays;
        self.changed.notify_all();
    }

    /// Takes up to `want` rays (at least one when `want` > 0), blocking while none are
    /// left; `None` once stopped. The caller traces that many and reports them
    /// [`traced`](Self::traced).
    pub fn take(&self, want: u64) -> Option<u64> {
        let mut g = self.lock();
        loop {
            if g.stopped {
                return None;
            }
            let left = g.granted - g.taken;
            if left > 0 || want == 0 {
                let n = want.min(left);
                g.taken += n;
                return Some(n);
            }
            g = self.wait(g);
        }
    }

    /// `rays` taken have been traced.
    pub fn traced(&self, rays: u64) {
        let mut g = self.lock();
        g.traced += rays;
        debug_assert!(g.traced <= g.taken, "traced more than was taken");
        drop(g);
        self.changed.notify_all();
    }

    /// Waits until every granted ray is traced or the threads have nothing left to trace
    /// (the rest is withdrawn), or the allowance is stopped (likewise).
    pub fn settle(&self) -> Settled {
        let mut g = self.lock();
        while !g.settled() {
            g = self.wait(g);
        }
        // Stopped or starved: nothing more is taken, so the untaken rest goes (what was
        // taken and is still being traced when stopped is not counted).
        let withdrawn = g.granted - g.taken;
        g.granted = g.taken;
        g.withdrawn += withdrawn;
        let traced = g.traced - g.settled;
        g.settled = g.traced;
        Settled { traced, withdrawn }
    }

    /// Wakes every waiting thread and holder; from now on nothing is taken.
    pub fn stop(&self) {
        self.lock().stopped = true;
        self.changed.notify_all();
    }

    pub fn totals(&self) -> Totals {
        let g = self.lock();
        Totals {
            granted: g.granted + g.withdrawn,
            taken: g.taken,
            traced: g.traced,
            withdrawn: g.withdrawn,
        }
    }

    /// A worker thread starts; its slot for [`found_work`](Self::found_work).
    pub(crate) fn join(&self) -> usize {
        let mut g = self.lock();
        g.idle.push(Some(false));
        g.idle.len() - 1
    }

    /// A worker thread ends.
    pub(crate) fn leave(&self, slot: usize) {
        self.lock().idle[slot] = None;
        self.changed.notify_all();
    }

    /// Worker `slot` asked the server for work and got some (`true`) or none.
    pub(crate) fn found_work(&self, slot: usize, some: bool) {
        let mut g = self.lock();
        if let Some(idle) = &mut g.idle[slot] {
            *idle = !some;
        }
        drop(g);
        self.changed.notify_all();
    }

    /// The work may have grown (a display's request): a thread that found none must ask
    /// again before the threads count as out of work. Called under the server's lock, so
    /// that a thread's answer is ordered with the change.
    pub(crate) fn work_changed(&self) {
        for idle in self.lock().idle.iter_mut().flatten() {
            *idle = false;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;
    use std::thread;

    /// Waits (yielding, no sleeps) until `n` threads are blocked in the allowance.
    fn until_waiting(a: &RayAllowance, n: usize) {
        while a.lock().waiting < n {
            thread::yield_now();
        }
    }

    #[test]
    fn takes_are_cut_to_what_is_granted_and_settle_counts_what_was_traced() {
        let a = RayAllowance::new();
        let w = a.join();
        a.grant(100);
        assert_eq!(a.take(64), Some(64));
        assert_eq!(a.take(64), Some(36), "only the rest of the grant");
        a.traced(100);
        assert_eq!(
            a.settle(),
            Settled {
                traced: 100,
                withdrawn: 0
            }
        );
        a.grant(10);
        assert_eq!(a.take(3), Some(3));
        a.traced(3);
        // The worker found no more work: the other 7 are withdrawn, not saved up.
        a.found_work(w, false);
        assert_eq!(
            a.settle(),
            Settled {
                traced: 3,
                withdrawn: 7
            }
        );
        a.found_work(w, true);
        a.grant(5);
        assert_eq!(a.take(64), Some(5), "the withdrawn 7 are gone");
        a.traced(5);
        assert_eq!(a.settle().traced, 5);
        assert_eq!(
            a.totals(),
            Totals {
                granted: 115,
                taken: 108,
                traced: 108,
                withdrawn: 7
            }
        );
    }

    #[test]
    fn settling_waits_for_rays_granted_taken_or_in_flight() {
        let a = RayAllowance::new();
        let w = a.join();
        a.grant(10);
        assert!(
            !a.lock().settled(),
            "granted, not taken, the thread has work"
        );
        a.take(10);
        a.found_work(w, false);
        assert!(!a.lock().settled(), "taken, not yet traced");
        a.traced(4);
        assert!(!a.lock().settled(), "partly traced");
        a.traced(6);
        assert!(a.lock().settled());
        a.grant(1);
        assert!(a.lock().settled(), "granted, but no thread has work");
        a.found_work(w, true);
        assert!(!a.lock().settled());
    }

    /// A thread blocked in `take` (nothing left) returns `None` when stopped, and a holder
    /// blocked in `settle` returns. Without the wake-up the joins would wait forever: the
    /// test fails by hanging.
    #[test]
    fn stop_wakes_a_blocked_worker_and_a_settling_holder() {
        let a = Arc::new(RayAllowance::new());
        a.join();
        a.grant(5);
        assert_eq!(a.take(5), Some(5));
        let worker = {
            let a = a.clone();
            thread::spawn(move || a.take(8))
        };
        let holder = {
            let a = a.clone();
            thread::spawn(move || a.settle())
        };
        until_waiting(&a, 2);
        a.stop();
        assert_eq!(worker.join().unwrap(), None);
        assert_eq!(holder.join().unwrap(), Settled::default());
        assert_eq!(a.take(1), None, "nothing is taken once stopped");
    }

    #[test]
    fn a_blocked_take_wakes_on_a_grant() {
        let a = Arc::new(RayAllowance::new());
        let t = {
            let a = a.clone();
            thread::spawn(move || a.take(50))
        };
        until_waiting(&a, 1);
        a.grant(20);
        assert_eq!(t.join().unwrap(), Some(20));
    }

    #[test]
    fn a_change_of_work_makes_idle_threads_ask_again() {
        let a = RayAllowance::new();
        let (w1, w2) = (a.join(), a.join());
        a.found_work(w1, false);
        a.found_work(w2, false);
        assert!(a.lock().starved());
        a.work_changed();
        assert!(!a.lock().starved(), "a new request may be work for them");
        a.found_work(w1, false);
        assert!(!a.lock().starved(), "w2 has not asked since");
        a.leave(w2);
        assert!(a.lock().starved(), "a thread that left does not count");
    }
}
