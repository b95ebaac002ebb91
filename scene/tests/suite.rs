//! The crate's integration tests as one binary (one link, not one per file): each
//! file of this folder is a module.

mod common;

mod bvh_queries;
mod daylight;
mod generated_scenes;
mod gltf_inputs;
mod objects;
mod real_scenes;
mod weather;

#[path = "../../tests/common/suite_files.rs"]
mod suite_files;
