//! In-process worker threads: each takes packets from the server, traces them with the
//! [`SampleSource`] and returns the results, waiting for new work when there is none.
//! Held to a [`RayAllowance`](super::RayAllowance), a thread takes rays from it before
//! tracing them (a packet in parts when the allowance is short), reports them traced
//! (a packet's last part once its samples are stored), and tells it whether the server
//! had work.

use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use super::state::State;
use crate::worker::{SampleSource, trace_packet, trace_packet_in_parts};

/// Starts `n` worker threads.
pub(crate) fn spawn(
    state: &Arc<State>,
    source: &Arc<dyn SampleSource>,
    n: usize,
) -> Vec<JoinHandle<()>> {
    (0..n)
        .map(|i| {
            let (st, src) = (state.clone(), source.clone());
            // Registered before the thread runs, so a holder never sees fewer threads.
            let slot = st.allowance.as_ref().map(|a| a.join());
            std::thread::Builder::new()
                .name(format!("holodeck-worker-{i}"))
                .spawn(move || work(&st, &*src, slot))
                .expect("spawn worker thread")
        })
        .collect()
}

fn work(st: &State, source: &dyn SampleSource, slot: Option<usize>) {
    let held = st.allowance.as_deref().zip(slot);
    let id = st.lock().add_worker();
    while !st.stopping() {
        let packets = {
            let mut s = st.lock();
            let p = s.next_packets(id, st.now());
            // Told under the server's lock, so ordered with a request's change of work.
            if let Some((a, slot)) = held {
                a.found_work(slot, !p.is_empty());
            }
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
            // Held: the rays of the part being traced, reported traced once done (the
            // last part's once its samples are stored and on their way to the displays).
            let mut owed = 0;
            let result = match held {
                None => Some(trace_packet(source, &p, st.distance)),
                Some((a, _)) => trace_packet_in_parts(source, &p, st.distance, |left| {
                    a.traced(std::mem::take(&mut owed));
                    owed = a.take(left as u64)?;
                    Some(owed as usize)
                })
                .transpose(),
            };
            let Some(result) = result else {
                break; // stopped while waiting for rays
            };
            let result = result.expect("packets built by the server are whole records");
            if let Err(e) = st.complete(id, &result) {
                tracing::warn!("worker thread: {e}");
            }
            if let Some((a, _)) = held {
                a.traced(owed);
            }
        }
    }
    st.lock().remove_worker(id);
    if let Some((a, slot)) = held {
        a.leave(slot);
    }
}
