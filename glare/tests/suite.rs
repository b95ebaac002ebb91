//! The crate's integration tests as one binary (one link, not one per file): each
//! file of this folder is a module.

mod annual;
mod figures;
mod meter;

#[path = "../../tests/common/suite_files.rs"]
mod suite_files;
