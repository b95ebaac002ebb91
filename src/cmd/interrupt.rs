//! Ctrl-C: the binary's one signal handler, for SIGINT, SIGTERM and SIGHUP alike (a
//! supervisor's or systemd's stop is a Ctrl-C), installed by `main` before any command
//! runs, so every command in every phase ends on it with [`INTERRUPTED`].
//!
//! By default Ctrl-C ends the process at once: a phase that keeps nothing, or keeps its
//! work on disk as it goes, whole (a bake's finished bounces, each file written aside and
//! renamed; a holodeck's commits), loses nothing by it, and says what it keeps
//! ([`ending_at_once`]). A command that ends its steps itself instead takes the flag
//! ([`ctrl_c_flag`]): libraries never install handlers, they take a stop flag
//! (`holodeck::run::RunOptions::stop`, `master::cluster::MasterOptions::stop`), so a long
//! run (a fill, a master, a hosted holodeck) ends its current step, commits what was traced
//! and says goodbye to its peers instead of dying mid-write; it then ends with
//! [`exit_interrupted`]. A second Ctrl-C ends any command at once.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

/// The exit status of a command Ctrl-C ended (128 + SIGINT, as a shell reports it).
pub const INTERRUPTED: i32 = 130;

/// What Ctrl-C does now.
enum Phase {
    /// Ends the process at once, saying what is kept (empty: nothing to say).
    AtOnce(String),
    /// Sets the flag: the command ends its current step and stops by itself.
    Flag,
}

static PHASE: Mutex<Phase> = Mutex::new(Phase::AtOnce(String::new()));

/// The flag Ctrl-C sets in [`Phase::Flag`].
static FLAG: OnceLock<Arc<AtomicBool>> = OnceLock::new();

fn phase() -> std::sync::MutexGuard<'static, Phase> {
    PHASE.lock().unwrap_or_else(|e| e.into_inner())
}

fn flag() -> &'static Arc<AtomicBool> {
    FLAG.get_or_init(Arc::default)
}

/// Installs the handler (once, before the command runs): from here on Ctrl-C ends the
/// process with [`INTERRUPTED`] until a command takes the flag.
pub fn install() {
    if let Err(e) = ctrlc::set_handler(on_ctrl_c) {
        tracing::warn!("no Ctrl-C handler ({e}): Ctrl-C ends the process at once");
    }
}

/// The handler: ends the process, or sets the flag the first time in [`Phase::Flag`].
fn on_ctrl_c() {
    let kept = match &*phase() {
        Phase::AtOnce(kept) => kept.clone(),
        Phase::Flag if !flag().swap(true, Ordering::SeqCst) => {
            return tracing::info!("interrupted: stopping cleanly (Ctrl-C again ends at once)");
        }
        Phase::Flag => "interrupted twice: ending at once".to_owned(),
    };
    exit_interrupted(&kept);
}

/// Ends the process as Ctrl-C does: says `kept` (what stays on disk, and how to go on; empty:
/// nothing) on stderr and exits with [`INTERRUPTED`].
pub fn exit_interrupted(kept: &str) -> ! {
    if kept.is_empty() {
        eprintln!("interrupted");
    } else {
        eprintln!("interrupted: {kept}");
    }
    std::process::exit(INTERRUPTED)
}

/// Runs `f` as a phase that Ctrl-C ends at once: the process says `kept` and exits with
/// [`INTERRUPTED`]. After it, Ctrl-C does what it did before.
pub fn ending_at_once<T>(kept: String, f: impl FnOnce() -> T) -> T {
    let before = std::mem::replace(&mut *phase(), Phase::AtOnce(kept));
    let out = f();
    *phase() = before;
    out
}

/// The flag Ctrl-C sets from now on instead of ending the process: the caller ends its
/// steps when it is set (and then [`exit_interrupted`]).
pub fn ctrl_c_flag() -> Arc<AtomicBool> {
    *phase() = Phase::Flag;
    flag().clone()
}

/// Whether Ctrl-C was pressed while a command held the flag.
pub fn interrupted() -> bool {
    flag().load(Ordering::SeqCst)
}
