//! The physical CAVE: the configuration file (walls, user, room, tracking, navigation,
//! cluster) and its validation into a [`Cave`] of [`Wall`]s, the off-axis stereo frusta of
//! every wall and eye (Kooima, *Generalized Perspective Projection*), and the eye views a
//! head pose gives every wall ([`CaveFrusta`]); the walls' windows and the unfolded CAVE
//! that mosaics and previews lay them out in; and the one view type, [`WallView`] (an eye,
//! a screen rectangle and its image), and an image's [`Size`].
//!
//! This is the one place the projection is computed: the master sends its matrices to the
//! render nodes, and a standalone node draws the same frusta.

pub mod config;
pub mod frustum;
pub mod navigation;
pub mod screen;
pub mod size;
pub mod unfolded;
pub mod validate;
pub mod window;

pub use config::CaveFile;
pub use frustum::{CaveFrusta, Eye, Frustum, FrustumFault, eye_position, off_axis, wall_frusta};
pub use navigation::{Navigation, NavigationSection, TravelMode};
pub use screen::WallView;
pub use size::Size;
pub use unfolded::{Place, Unfolded, unfold};
pub use validate::{Cave, ConfigError, MIN_EYE_DISTANCE, Wall, load_cave, parse_cave};
pub use window::{Fullscreen, Layout, Monitor, PresentMode, WindowSettings};
