//! The crate's integration tests as one binary (one link, not one per file): each
//! file of this folder is a module.

// `common` and `ray_sets` each include `tests/common/require.rs` by path, as the benches
// that include either of them alone need it.
#![allow(clippy::duplicate_mod)]

mod common;
mod ray_sets;

mod cache;
mod gpu_rays;
mod holodeck_source;
mod moving_objects;
mod moving_viewer;
mod repeatable;
mod still_viewer;
mod threaded;
mod vlf_base;

#[path = "../../tests/common/suite_files.rs"]
mod suite_files;
