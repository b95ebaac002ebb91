//! The command line of each wall's node process in `sim`.

use std::process::Command;

use anyhow::{Context, Result};
use holocave_cave::Wall;
use holocave_render_node::present::output::PRESENTED_LOG;

use super::SimSpec;
use crate::launch::SECRET_VAR;
use crate::supervise::Relaunch;

/// What a node writes in its folder that a run starts afresh: the frames it presented, and
/// when its windows presented them.
const FRESH_EACH_RUN: [&str; 2] = [PRESENTED_LOG, "present-times.log"];

/// The supervisor's name for `wall`'s node.
pub fn node_name(wall: &str) -> String {
    format!("node {wall}")
}

/// `wall`'s node with its `own` flags, its output in `OUT/<wall>/` (a fresh presented log
/// and `node.log`; a restart appends to both), to be started by the supervisor.
pub(super) fn child(spec: &SimSpec, wall: &Wall, own: &[String]) -> Result<(String, Relaunch)> {
    let eye = (spec.unfolded.place(&wall.name))
        .with_context(|| format!("wall {:?} is not in the unfolded CAVE", wall.name))?
        .size;
    let dir = spec.out.join(&wall.name);
    std::fs::create_dir_all(&dir).with_context(|| format!("{}", dir.display()))?;
    for name in FRESH_EACH_RUN {
        let _ = std::fs::remove_file(dir.join(name));
    }
    let log = dir.join("node.log");
    std::fs::File::create(&log).with_context(|| format!("{}", log.display()))?;
    let mut command = Command::new(spec.exe);
    command
        .arg("node")
        .args(["--master", spec.master, "--wall", &wall.name])
        .args(own)
        .arg("--scene")
        .arg(spec.scene)
        .args(spec.daylight)
        .arg("--out")
        .arg(spec.out)
        .args(["--size", &eye.to_string()])
        .args(&spec.node_flags)
        .env(SECRET_VAR, secret_text(spec))
        // Four nodes share this machine's cores: one tracing thread each.
        .env("RAYON_NUM_THREADS", "1");
    Ok((node_name(&wall.name), Relaunch::new(&command, &log)))
}

/// The cluster's secret as the nodes take it from their environment.
fn secret_text(spec: &SimSpec) -> String {
    String::from_utf8_lossy(&spec.credentials.secret).into_owned()
}
