//! What some tests need from outside the checkout — the real scenes and tracker traces in
//! `../shared` beside it, the Xvfb and xwd programs — and what they do without it: they
//! say which test skipped (or fell back) and what was missing, except with
//! `HOLOCAVE_REQUIRE_SHARED=1` (CI: `.ci/run`), where the absence fails the test.
//!
//! One file for every crate's tests: the binary's `tests/common` holds it, and the other
//! crates' test helpers include it by path.

#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// The variable that turns a missing input into a failure.
pub const REQUIRE: &str = "HOLOCAVE_REQUIRE_SHARED";

/// True where every input must be present (`HOLOCAVE_REQUIRE_SHARED=1`).
pub fn required() -> bool {
    std::env::var(REQUIRE).as_deref() == Ok("1")
}

/// The running test's name (libtest names each test's thread after it).
fn test_name() -> String {
    std::thread::current()
        .name()
        .filter(|n| *n != "main")
        .unwrap_or("a test")
        .to_owned()
}

/// `what` is missing and the test does `instead` (e.g. "skipped"): says so on stderr
/// naming the test; with `HOLOCAVE_REQUIRE_SHARED=1` fails the test instead.
pub fn missing(what: &str, instead: &str) {
    let test = test_name();
    assert!(!required(), "{test}: {REQUIRE}=1 and {what}");
    eprintln!("{test}: {instead}: {what}");
}

/// [`missing`], and the test is skipped (the caller returns).
pub fn skip(what: &str) {
    missing(what, "SKIPPED");
}

/// The checkout: the nearest folder above this crate's that holds `Cargo.lock`.
pub fn checkout() -> PathBuf {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    manifest
        .ancestors()
        .find(|d| d.join("Cargo.lock").is_file())
        .unwrap_or(manifest)
        .to_owned()
}

/// `../shared/<rel>` beside the checkout if it exists; otherwise [`missing`] (doing
/// `instead`) and `None`.
pub fn shared_or(rel: &str, instead: &str) -> Option<PathBuf> {
    let p = checkout().join("../shared").join(rel);
    if p.exists() {
        return Some(p);
    }
    missing(
        &format!(
            "{} is absent (the shared scenes and traces live in ../shared beside the checkout)",
            p.display()
        ),
        instead,
    );
    None
}

/// `../shared/<rel>`, or `None` and the test is skipped.
pub fn shared(rel: &str) -> Option<PathBuf> {
    shared_or(rel, "SKIPPED")
}

/// True when every one of `programs` is on the PATH; otherwise the test is skipped
/// naming the missing ones and `install` (how to get them).
pub fn programs(programs: &[&str], install: &str) -> bool {
    let on_path = |program: &&str| {
        std::env::var_os("PATH")
            .is_some_and(|paths| std::env::split_paths(&paths).any(|d| d.join(program).is_file()))
    };
    let absent: Vec<&str> = programs.iter().filter(|p| !on_path(p)).copied().collect();
    if absent.is_empty() {
        return true;
    }
    skip(&format!("{absent:?} not found ({install})"));
    false
}
