//! The holocave master's geometry: the CAVE configuration (walls, user, tracking,
//! navigation), its validation, and the off-axis stereo frusta of every wall and eye.

pub mod config;
pub mod frustum;
pub mod validate;

pub use config::CaveFile;
pub use frustum::{CaveFrusta, Frustum, FrustumFault};
pub use validate::{Cave, ConfigError, Wall, load_cave, parse_cave};
