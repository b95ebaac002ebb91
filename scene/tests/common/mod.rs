//! Helpers shared by the scene crate's integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use holocave_scene::{LoadOptions, Scene};

/// A file of the project (relative to the workspace root).
pub fn project_path(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

/// A file of the read-only shared scenes beside the checkout (`../shared/scenes`), or
/// `None` (with a message saying the test is skipped) when they are absent. With
/// `HOLOCAVE_REQUIRE_SHARED=1` (as CI sets it) an absent file fails the test instead.
pub fn shared_scene(rel: &str) -> Option<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenes");
    let p = root.join(rel);
    if p.exists() {
        return Some(p);
    }
    let why = format!(
        "{} is absent (the shared scenes live in ../shared/scenes beside the checkout)",
        p.display()
    );
    assert!(
        std::env::var("HOLOCAVE_REQUIRE_SHARED").as_deref() != Ok("1"),
        "HOLOCAVE_REQUIRE_SHARED=1 and {why}"
    );
    eprintln!("SKIPPED: {why}");
    None
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
