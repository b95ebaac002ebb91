//! What the binary's end-to-end tests share: the `holocave` command run from the checkout,
//! child processes that cannot outlive a failing test, a scratch folder per test, a master
//! started on an ephemeral port, and the standalone node on the Cornell box's front wall.

#![allow(dead_code)]

pub mod require;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{ChildStdout, Command, Stdio};

pub use holocave::launch::Watched;

/// The checkout: configs and scenes are named relative to it.
pub fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// `holocave` with the checkout as its working directory.
pub fn holocave() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_holocave"));
    c.current_dir(root());
    c
}

/// `holocave node --standalone` on the front wall of `configs/cave4-cornell.toml`, looking
/// at the Cornell box; the caller adds the view, the frames and the output.
pub fn cornell_front_node() -> Command {
    front_node(Path::new("configs/cave4-cornell.toml"))
}

/// The same with another CAVE config (relative to the checkout, or absolute).
pub fn front_node(config: &Path) -> Command {
    let mut c = holocave();
    c.args(["node", "--standalone", "--config"])
        .arg(config)
        .args(["--wall", "front", "--scene", "scenes/cornell.gltf"]);
    c
}

/// An empty folder of this test's own under the system's temporary folder.
pub fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("holocave-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Starts `master` (a `holocave master …` command listening on port 0) with its output
/// piped; returns it, the address its first line names, and the rest of its stdout.
pub fn start_master(mut master: Command) -> (Watched, String, BufReader<ChildStdout>) {
    let mut child = master
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start holocave master");
    let mut out = BufReader::new(child.stdout.take().unwrap());
    let mut line = String::new();
    out.read_line(&mut line).unwrap();
    let addr = line
        .trim()
        .strip_prefix("master listening on ")
        .unwrap_or_else(|| panic!("unexpected first line {line:?}"))
        .to_owned();
    (Watched::adopt("master", child), addr, out)
}
