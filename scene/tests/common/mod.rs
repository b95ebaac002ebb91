//! Helpers shared by the scene crate's integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use holocave_scene::{LoadOptions, Scene};

/// A file of the project (relative to the workspace root).
pub fn project_path(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

#[path = "../../../tests/common/require.rs"]
mod require;

/// A file of the read-only shared scenes beside the checkout (`../shared/scenes`), or
/// `None` when they are absent: the test is skipped, or fails where
/// `HOLOCAVE_REQUIRE_SHARED=1` (CI), as `require` says.
pub fn shared_scene(rel: &str) -> Option<PathBuf> {
    require::shared(&format!("scenes/{rel}"))
}

/// A file of the shared folder beside the checkout (`../shared/<rel>`), or `None` as
/// [`shared_scene`].
pub fn shared_file(rel: &str) -> Option<PathBuf> {
    require::shared(rel)
}

/// Loads a scene leniently; a load error is a test failure that shows the error.
pub fn load(path: &Path) -> Scene {
    match Scene::load(path, &LoadOptions::default()) {
        Ok(s) => s,
        Err(e) => panic!("loading {}: {e}", path.display()),
    }
}

/// Reads a glTF file's JSON (for comparing what was loaded with what the file says).
pub fn json(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap();
    serde_json::from_str(&text).unwrap()
}

/// The number parsed from a "dropped N degenerate" warning, 0 when there is none.
pub fn dropped_degenerate(scene: &Scene) -> usize {
    let found: Vec<&String> = scene
        .warnings
        .iter()
        .filter(|w| w.contains("degenerate"))
        .collect();
    assert!(
        found.len() <= 1,
        "degenerate triangles warned more than once: {found:?}"
    );
    found
        .first()
        .map(|w| {
            w.split_whitespace()
                .find_map(|t| t.parse::<usize>().ok())
                .unwrap_or_else(|| panic!("no count in {w:?}"))
        })
        .unwrap_or(0)
}
