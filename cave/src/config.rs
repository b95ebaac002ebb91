//! The CAVE configuration file (TOML) as written: walls, user, room, tracking and
//! navigation. [`crate::validate`] turns it into a checked [`crate::validate::Cave`].

use holocave_tracking::guard::GuardConfig;
use holocave_tracking::params::{FilterConfig, PredictionConfig};
use serde::{Deserialize, Serialize};

/// A whole CAVE file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaveFile {
    #[serde(default)]
    pub room: RoomConfig,
    #[serde(default)]
    pub user: UserConfig,
    pub tracking: TrackingSection,
    /// Room → scene at the start (where the physical room sits in the scene), and the
    /// devices and settings of travel.
    #[serde(default)]
    pub navigation: crate::navigation::NavigationSection,
    #[serde(rename = "wall")]
    pub walls: Vec<WallConfig>,
    #[serde(default)]
    pub cluster: ClusterConfig,
}

/// How the master and the render nodes find and trust each other, and the frame clock.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ClusterConfig {
    /// The cluster's name; a node of another cluster is refused.
    pub id: String,
    /// Where the master listens for render nodes (`HOST:PORT`).
    pub master: String,
    /// The shared secret every node proves it knows (HMAC challenge–response). Required to
    /// run a cluster; the `HOLOCAVE_SECRET` environment variable overrides it.
    pub secret: String,
    /// Frames per second of the master's clock.
    pub rate_hz: f64,
    /// The dead-node timeout (milliseconds): every wall swaps only when every live node is
    /// ready (frame lock); a node that is not ready this long after a frame state was sent
    /// is declared out, and the others go on without it until it is ready again.
    pub dead_node_ms: f64,
    /// Where the holodeck server accepts workers and render nodes (`HOST:PORT`), when the
    /// master hosts it (`holocave master --holodeck FILE`).
    pub holodeck: String,
}

impl Default for ClusterConfig {
    fn default() -> Self {
        ClusterConfig {
            id: "holocave".to_owned(),
            master: "127.0.0.1:7400".to_owned(),
            secret: String::new(),
            rate_hz: 60.0,
            dead_node_ms: 250.0,
            holodeck: "127.0.0.1:7401".to_owned(),
        }
    }
}

/// The physical room.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RoomConfig {
    /// A point known to be inside the room (in front of every wall), metres. Wall normals
    /// are checked against it, and it is the eye position until tracking delivers one.
    pub inside: [f64; 3],
    /// The largest near-plane distance (m); closer to a wall it shrinks so it never clips it.
    pub near: f64,
}

impl Default for RoomConfig {
    fn default() -> Self {
        RoomConfig {
            inside: [0.0, 1.5, 0.0],
            near: 0.05,
        }
    }
}

/// The tracked user.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct UserConfig {
    /// Interpupillary distance, metres.
    pub ipd: f64,
    /// From the tracked point to the midpoint between the eyes, in the head's frame
    /// (+X right, +Y up, −Z forward), metres.
    pub head_to_eyes: [f64; 3],
}

impl Default for UserConfig {
    fn default() -> Self {
        UserConfig {
            ipd: 0.064,
            head_to_eyes: [0.0, 0.0, 0.0],
        }
    }
}

/// Where head poses come from and how they are filtered and predicted.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrackingSection {
    /// `vrpn://DEVICE@HOST[:PORT]`, `file:PATH` or `synthetic:NAME`.
    pub source: String,
    /// The tracker's sensor number that is the head.
    #[serde(default)]
    pub sensor: i32,
    /// Tracker coordinates → room coordinates.
    #[serde(default)]
    pub tracker_to_room: RigidTransform,
    #[serde(default)]
    pub guard: GuardConfig,
    #[serde(default)]
    pub filter: FilterConfig,
    #[serde(default)]
    pub prediction: PredictionConfig,
}

/// A rotation (unit quaternion `x, y, z, w`) followed by a translation (metres).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RigidTransform {
    pub translation: [f64; 3],
    pub rotation: [f64; 4],
}

impl Default for RigidTransform {
    fn default() -> Self {
        RigidTransform {
            translation: [0.0; 3],
            rotation: [0.0, 0.0, 0.0, 1.0],
        }
    }
}

/// How a wall shows stereo.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum StereoMode {
    /// Left and right eye (active stereo or a side-by-side pair).
    Pair,
    /// One view from between the eyes.
    Mono,
    /// Only the left eye (passive stereo: this projector shows the left image).
    Left,
    /// Only the right eye.
    Right,
}

/// One wall as written.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WallConfig {
    pub name: String,
    /// Lower-left corner, room metres.
    pub pa: [f64; 3],
    /// Lower-right corner.
    pub pb: [f64; 3],
    /// Upper-left corner.
    pub pc: [f64; 3],
    /// Width and height in pixels.
    pub pixels: [i64; 2],
    pub stereo: StereoMode,
    /// The render node that drives it.
    pub node: String,
    /// Its windows (`[[wall.window]]`); none: one in the stereo mode's default layout.
    #[serde(default, rename = "window", skip_serializing_if = "Vec::is_empty")]
    pub windows: Vec<crate::window::WindowConfig>,
}
