//! Ctrl-C: the binary's one signal handler. Libraries never install handlers; they take a
//! stop flag (`holodeck::run::RunOptions::stop`, `master::cluster::MasterOptions::stop`)
//! and this sets it, so a long run (a fill, a master, a hosted holodeck) ends its current
//! step, commits what was traced and says goodbye to its peers instead of dying mid-write.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

/// The flag Ctrl-C sets, its handler installed on the first call (once per process).
pub fn ctrl_c_flag() -> Arc<AtomicBool> {
    static FLAG: OnceLock<Arc<AtomicBool>> = OnceLock::new();
    FLAG.get_or_init(|| {
        let flag = Arc::new(AtomicBool::new(false));
        let set = flag.clone();
        if let Err(e) = ctrlc::set_handler(move || {
            tracing::info!("interrupted: stopping cleanly");
            set.store(true, Ordering::SeqCst);
        }) {
            tracing::warn!("no Ctrl-C handler ({e}): Ctrl-C ends the process at once");
        }
        flag
    })
    .clone()
}
