//! The holocave master: the CAVE configuration (walls, user, tracking, navigation, cluster),
//! its validation, the off-axis stereo frusta of every wall and eye, the tracked head, and
//! the running cluster master (frame clock, frame states, swap barrier).

pub mod barrier;
pub mod cluster;
pub mod config;
pub mod frame_state;
pub mod frustum;
pub mod head;
pub mod validate;

pub use config::CaveFile;
pub use frustum::{CaveFrusta, Frustum, FrustumFault};
pub use validate::{Cave, ConfigError, Wall, load_cave, parse_cave};
