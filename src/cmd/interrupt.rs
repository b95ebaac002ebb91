//! Ctrl-C: the binary's one signal handler, for SIGINT, SIGTERM and SIGHUP alike (a
//! supervisor's or systemd's stop is a Ctrl-C). Libraries never install handlers; they take a
//! stop flag (`holodeck::run::RunOptions::stop`, `master::cluster::MasterOptions::stop`)
//! and this sets it, so a long run (a fill, a master, a hosted holodeck) ends its current
//! step, commits what was traced and says goodbye to its peers instead of dying mid-write.
//! A phase whose work is kept on disk as it goes, whole (a bake's finished bounces, each
//! file written aside and renamed), is ended at once instead ([`ending_at_once`]): its
//! steps can take the whole run.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

/// The exit status of a command Ctrl-C ended (128 + SIGINT, as a shell reports it).
pub const INTERRUPTED: i32 = 130;

/// While a phase that Ctrl-C ends at once runs: what is kept, said as it ends.
static AT_ONCE: Mutex<Option<String>> = Mutex::new(None);

/// Runs `f` as a phase that Ctrl-C ends at once: the process says `kept` (what stays on
/// disk, and how to go on) and exits with [`INTERRUPTED`].
pub fn ending_at_once<T>(kept: String, f: impl FnOnce() -> T) -> T {
    ctrl_c_flag();
    *AT_ONCE.lock().unwrap_or_else(|e| e.into_inner()) = Some(kept);
    let out = f();
    *AT_ONCE.lock().unwrap_or_else(|e| e.into_inner()) = None;
    out
}

/// The flag Ctrl-C sets, its handler installed on the first call (once per process).
pub fn ctrl_c_flag() -> Arc<AtomicBool> {
    static FLAG: OnceLock<Arc<AtomicBool>> = OnceLock::new();
    FLAG.get_or_init(|| {
        let flag = Arc::new(AtomicBool::new(false));
        let set = flag.clone();
        if let Err(e) = ctrlc::set_handler(move || {
            if let Some(kept) = AT_ONCE.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
                eprintln!("interrupted: {kept}");
                std::process::exit(INTERRUPTED);
            }
            tracing::info!("interrupted: stopping cleanly");
            set.store(true, Ordering::SeqCst);
        }) {
            tracing::warn!("no Ctrl-C handler ({e}): Ctrl-C ends the process at once");
        }
        flag
    })
    .clone()
}
