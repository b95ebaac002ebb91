//! The commit thread: commits every `every`; a failed commit records the error and stops
//! the run.

use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use super::state::State;

pub(crate) fn spawn(state: &Arc<State>, every: Duration) -> JoinHandle<()> {
    let st = state.clone();
    std::thread::Builder::new()
        .name("holodeck commits".into())
        .spawn(move || {
            let mut last = Instant::now();
            while !st.stopping() {
                if last.elapsed() >= every {
                    if let Err(e) = st.commit() {
                        tracing::error!("commit failed: {e}; stopping");
                        *st.error.lock().unwrap_or_else(|p| p.into_inner()) = Some(e);
                        st.set_stop();
                        break;
                    }
                    last = Instant::now();
                }
                std::thread::sleep(Duration::from_millis(50));
            }
        })
        .expect("spawn the commit thread")
}
