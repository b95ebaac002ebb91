//! The crate's integration tests as one binary (one link, not one per file): each
//! file of this folder is a module.

mod common;

mod albedo;
mod all_scenes;
mod bsdf_sampling;
mod cave_holodeck;
mod convergence;
mod determinism;
mod direct_emission;
mod distances;
mod furnace;
mod lamp_choice;
mod mirror_light;
mod stability;

#[path = "../../tests/common/suite_files.rs"]
mod suite_files;
