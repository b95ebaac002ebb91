//! The holodeck of holocave (`papers/holodeck-ray-cache.md`, §2.1–2.3 and Appendix A): a
//! persistent, crash-safe 4-D ray cache. Rays are stored by the *beam* (pair of wall cells
//! of a *section*) they cross, ten bytes per sample, in a portable file that survives being
//! killed at any instant; a server keeps recently used beams in memory, serves requests and
//! feeds ray packets to worker threads and TCP worker processes.

pub mod auth;
pub mod beam_index;
pub mod cache;
pub mod cave_section;
pub mod display;
pub mod distance_code;
pub mod file;
pub mod free_space;
pub mod proximity;
pub mod requests;
pub mod rgbe;
pub mod run;
pub mod sample;
pub mod scene_id;
pub mod section;
pub mod server;
pub mod serving;
pub mod view;
pub mod worker;

pub use file::{FileError, HoloFile};
pub use sample::PackedSample;
pub use section::{Section, ViewClass};
