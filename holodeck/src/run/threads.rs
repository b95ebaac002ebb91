//! In-process worker threads: each takes packets from the server, traces them with the
//! [`SampleSource`] and returns the results, waiting for new work when there is none.

use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use super::state::State;
use crate::worker::{SampleSource, trace_packet};

/// Starts `n` worker threads.
pub(crate) fn spawn(
    state: &Arc<State>,
    source: &Arc<dyn SampleSource>,
    n: usize,
) -> Vec<JoinHandle<()>> {
    (0..n)
        .map(|i| {
            let (st, src) = (state.clone(), source.clone());
            std::thread::Builder::new()
                .name(format!("holodeck-worker-{i}"))
                .spawn(move || work(&st, &*src))
                .expect("spawn worker thread")
        })
        .collect()
}

fn work(st: &State, source: &dyn SampleSource) {
    let id = st.lock().add_worker();
    while !st.stopping() {
        let packets = {
            let mut s = st.lock();
            let p = s.next_packets(id, st.now());
            if p.is_empty() {
                // Nothing to do now: wait for a change (or the stop).
                let _ = st.wake.wait_timeout(s, Duration::from_millis(200));
                continue;
            }
            p
        };
        for p in packets {
            if st.stopping() {
                break;
            }
            let result = trace_packet(source, &p, st.distance)
                .expect("packets built by the server are whole records");
            if let Err(e) = st.complete(id, &result) {
                tracing::warn!("worker thread: {e}");
            }
        }
    }
    st.lock().remove_worker(id);
}
