//! The crate's integration tests as one binary (one link, not one per file): each
//! file of this folder is a module.

mod common;

mod auth;
mod crash;
mod display;
mod free_space;
mod workers;

#[path = "../../tests/common/suite_files.rs"]
mod suite_files;
