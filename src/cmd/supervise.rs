//! `holocave supervise`: one process of a real cluster (the master, a wall's node, a
//! holodeck worker) kept running on its host as `sim` keeps its children
//! ([`crate::supervise`]): started again with the same command after a backoff when it
//! dies, and let go when it exits with success (its master said goodbye). Ctrl-C (or
//! SIGTERM, a service manager's stop) is passed on to it as SIGTERM, and this process
//! exits once it has, with status 130.

use std::ffi::OsString;
use std::path::PathBuf;
use std::process::Command;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use clap::Args;

use super::interrupt::{INTERRUPTED, ctrl_c_flag};
use holocave::supervise::{Backoff, Death, Relaunch, Supervisor};

/// How often this process looks whether it is done.
const POLL: Duration = Duration::from_millis(50);

/// How long a stopped child has to exit before it is killed: a node's goodbye, a
/// worker's last packet and a master's holodeck commit take well under this.
const STOP_WAIT: Duration = Duration::from_secs(10);

#[derive(Args, Debug)]
pub struct SuperviseArgs {
    /// The process's name in the log lines and the summary (default: the command's
    /// program and first argument, e.g. `holocave node`).
    #[arg(long)]
    pub name: Option<String>,
    /// The file its stdout and stderr are appended to, across restarts.
    #[arg(long, value_name = "FILE", default_value = "supervised.log")]
    pub log: PathBuf,
    /// Record a death and leave the process down (this process then exits with status 1).
    /// By default it is started again after 0.1 s, doubling to 1 s while it keeps dying
    /// soon after its start, back to 0.1 s once it has run 10 s.
    #[arg(long)]
    pub no_restart: bool,
    /// The command, after `--`: `holocave supervise --log front.log -- holocave node
    /// --master HOST:PORT --wall front`.
    #[arg(last = true, required = true, value_name = "COMMAND")]
    pub command: Vec<OsString>,
}

pub fn run(args: SuperviseArgs) -> Result<()> {
    let halt = ctrl_c_flag();
    let name = (args.name.clone()).unwrap_or_else(|| default_name(&args.command));
    let mut command = Command::new(&args.command[0]);
    command.args(&args.command[1..]);
    let child = (name.clone(), Relaunch::new(&command, &args.log));
    let restart = (!args.no_restart).then(Backoff::default);
    let supervisor = Supervisor::start(vec![child], restart, halt.clone())
        .with_context(|| format!("supervise: starting {name}"))?;
    eprintln!("supervising {name}: its output in {}", args.log.display());
    while !halt.load(Ordering::Relaxed) && !supervisor.finished() {
        std::thread::sleep(POLL);
    }
    let interrupted = halt.load(Ordering::Relaxed);
    if interrupted {
        supervisor.terminate();
    }
    let started = supervisor.started;
    let (mut children, deaths) = supervisor.stop();
    let unclean = children.wait(STOP_WAIT);
    report(started, &deaths);
    if interrupted {
        eprintln!("interrupted: {name} stopped{}", said(&unclean));
        std::process::exit(INTERRUPTED);
    }
    if let Some(last) = deaths.last().filter(|d| d.restarted.is_none()) {
        bail!("{name} died ({}) and was not started again", last.how);
    }
    eprintln!("{name} finished{}", said(&unclean));
    Ok(())
}

/// `holocave node` for `holocave node --master …`: the program's file name and the
/// first argument.
fn default_name(command: &[OsString]) -> String {
    let program = std::path::Path::new(&command[0]);
    let program = program.file_name().unwrap_or(program.as_os_str());
    let words = std::iter::once(program).chain(command.get(1).map(OsString::as_os_str));
    words
        .map(|w| w.to_string_lossy().into_owned())
        .collect::<Vec<_>>()
        .join(" ")
}

/// ` (…)` naming what went wrong as the children stopped; nothing where nothing did.
fn said(problems: &[String]) -> String {
    if problems.is_empty() {
        String::new()
    } else {
        format!(" ({})", problems.join("; "))
    }
}

/// Every death and restart, in seconds from the start, on stderr.
fn report(started: Instant, deaths: &[Death]) {
    let restarted = deaths.iter().filter(|d| d.restarted.is_some()).count();
    eprintln!("deaths: {}, started again: {restarted}", deaths.len());
    let secs = |t: Instant| t.duration_since(started).as_secs_f64();
    for d in deaths {
        let again = (d.restarted).map_or("not started again".to_string(), |t| {
            format!("started again at {:.2} s", secs(t))
        });
        eprintln!(
            "  {} died at {:.2} s ({}, after running {:.2} s); {again}",
            d.name,
            secs(d.at),
            d.how,
            d.ran.as_secs_f64()
        );
    }
}
