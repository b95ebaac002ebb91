//! The one way a command starts and watches other `holocave` processes (`sim`'s master,
//! nodes and workers; `fill --worker-processes`; the end-to-end tests): each child is named,
//! killed if its watcher is dropped first, and waited for within a limit, and a holodeck
//! worker's command line is made in one place.

use std::io::Read;
use std::path::Path;
use std::process::{Child, Command, ExitStatus};
use std::time::{Duration, Instant};

use holocave_holodeck::auth::Credentials;

/// How often a waiting watcher looks at its child again.
const POLL: Duration = Duration::from_millis(20);

/// A child process, killed when this is dropped.
pub struct Watched {
    pub name: String,
    pub child: Child,
}

impl Drop for Watched {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Watched {
    /// Starts `command` as `name`.
    pub fn spawn(name: impl Into<String>, command: &mut Command) -> std::io::Result<Watched> {
        let name = name.into();
        let child = command
            .spawn()
            .map_err(|e| std::io::Error::new(e.kind(), format!("starting {name}: {e}")))?;
        Ok(Watched { name, child })
    }

    /// Watches `child`, started elsewhere, as `name`.
    pub fn adopt(name: impl Into<String>, child: Child) -> Watched {
        Watched {
            name: name.into(),
            child,
        }
    }

    /// Waits up to `limit` for the child to exit by itself; `None` if it has not.
    pub fn wait_for(&mut self, limit: Duration) -> Option<ExitStatus> {
        let end = Instant::now() + limit;
        loop {
            match self.child.try_wait() {
                Ok(Some(status)) => return Some(status),
                Ok(None) if Instant::now() < end => std::thread::sleep(POLL),
                _ => return None,
            }
        }
    }

    /// Waits up to `limit` for the child to exit (killing it if it does not); its status
    /// (`None`: killed) and whatever of its stdout and stderr was piped and not taken.
    pub fn finish(mut self, limit: Duration) -> (Option<ExitStatus>, String, String) {
        let status = self.wait_for(limit);
        if status.is_none() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
        let (mut out, mut err) = (String::new(), String::new());
        if let Some(mut o) = self.child.stdout.take() {
            let _ = o.read_to_string(&mut out);
        }
        if let Some(mut e) = self.child.stderr.take() {
            let _ = e.read_to_string(&mut err);
        }
        (status, out, err)
    }
}

/// Children started together and stopped together.
#[derive(Default)]
pub struct Group(pub Vec<Watched>);

impl Group {
    /// Waits up to `limit` in all for every child to exit; kills the rest and names each
    /// child that failed or had to be killed.
    pub fn wait(&mut self, limit: Duration) -> Vec<String> {
        let end = Instant::now() + limit;
        let mut problems = Vec::new();
        for w in &mut self.0 {
            match w.wait_for(end.saturating_duration_since(Instant::now())) {
                Some(status) if status.success() => {}
                Some(status) => problems.push(format!("{} exited with {status}", w.name)),
                None => problems.push(format!("{} did not exit", w.name)),
            }
        }
        // Dropping the watchers kills whoever is left.
        self.0.clear();
        problems
    }
}

/// The environment variable that carries the cluster's secret to a child (and overrides
/// a config's).
pub const SECRET_VAR: &str = "HOLOCAVE_SECRET";

/// `holocave worker` filling the holodeck server at `server` by tracing `scene` under the
/// `daylight` flags (`--daylight`, `--when`, `--weather`; none: the file beside it), proving `credentials` (the secret handed over in
/// [`SECRET_VAR`]).
pub fn worker_command(
    exe: &Path,
    server: &str,
    scene: &Path,
    daylight: &[std::ffi::OsString],
    credentials: &Credentials,
) -> Command {
    let mut c = Command::new(exe);
    c.args([
        "worker",
        "--server",
        server,
        "--cluster",
        &credentials.cluster,
    ])
    .arg("--scene")
    .arg(scene)
    .args(daylight)
    .env(
        SECRET_VAR,
        String::from_utf8_lossy(&credentials.secret).as_ref(),
    );
    c
}
