//! The crate's integration tests as one binary (one link, not one per file): each
//! file of this folder is a module.

mod common;

mod accuracy;
mod breakfast;
mod caustics;
mod contact;
mod continuation;
mod corner;
mod determinism;
mod direct_light;
mod file;
mod furnace;
mod gather;
mod glass_reflection;
mod glossy;
mod glow_edges;
mod mirrored_gloss;
mod object_gather;
mod objects;
mod pixel_direct;
mod plane_smooth;
mod pools;
mod room;
mod sharpened_reflection;
mod sky_split;
mod stopping;
mod surface_edges;

#[path = "../../tests/common/suite_files.rs"]
mod suite_files;
