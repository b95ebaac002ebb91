//! Messages between the master and the render nodes: the frame cycle of Equalizer, VR
//! Juggler and friends. The master sends [`MasterMsg::Frame`] (the frame's state: head pose
//! and every wall's views); each node draws it and answers [`NodeMsg::Ready`]; once every
//! live node is ready (or the deadline passed) the master sends [`MasterMsg::Swap`] and the
//! nodes show the frame.
//!
//! Every connection starts with the handshake of [`crate::handshake`]; these messages
//! follow it, in length-prefixed frames of at most [`MAX_CLUSTER_FRAME`] bytes.

use serde::{Deserialize, Serialize};

/// The largest cluster message: a frame state of a few walls is well under a kilobyte; the
/// limit leaves room for many walls and long names, and bounds what a hostile peer can make
/// a reader allocate.
pub const MAX_CLUSTER_FRAME: u32 = 1 << 20;

/// A pose on the wire: position (metres) and unit quaternion `x, y, z, w`.
#[derive(Serialize, Deserialize, Debug, Clone, Copy, PartialEq)]
pub struct WirePose {
    pub position: [f32; 3],
    pub orientation: [f32; 4],
}

/// Which eye a view is for.
#[derive(Serialize, Deserialize, Debug, Clone, Copy, PartialEq, Eq)]
pub enum WireEye {
    Left,
    Right,
    Centre,
}

/// One eye's view of one wall, in scene coordinates (column-major matrices, wgpu depth).
#[derive(Serialize, Deserialize, Debug, Clone, Copy, PartialEq)]
pub struct EyeState {
    pub eye: WireEye,
    /// The eye position.
    pub position: [f64; 3],
    pub view: [f64; 16],
    pub proj: [f64; 16],
    /// The near-plane distance the projection uses.
    pub near: f64,
}

/// The views of one wall.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub struct WallState {
    pub wall: String,
    pub eyes: Vec<EyeState>,
}

/// Everything a node needs to draw one frame.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub struct FrameState {
    pub frame: u64,
    /// When the master made this state (ns on its clock; virtual in replay).
    pub master_time_ns: u64,
    /// When the frame is expected on the walls; the pose is predicted to this time.
    pub display_time_ns: u64,
    /// When the newest tracker sample used arrived (ns on the master's clock), for
    /// motion-to-photon latency; `None` before any sample.
    pub tracker_time_ns: Option<u64>,
    /// The predicted head pose in room coordinates.
    pub head: WirePose,
    pub walls: Vec<WallState>,
    /// Room → scene (the navigation transform), column-major.
    pub navigation: [f64; 16],
    /// Where each moving object is this frame (scene coordinates); every wall draws the
    /// same placement.
    pub objects: Vec<WireObject>,
}

/// A moving object's placement: the object named `name` (as the scene names it) turned by
/// `orientation` (unit quaternion `x, y, z, w`) and then moved to `position` (metres).
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub struct WireObject {
    pub name: String,
    pub position: [f32; 3],
    pub orientation: [f32; 4],
}

impl FrameState {
    /// The views of the wall called `name`.
    pub fn wall(&self, name: &str) -> Option<&WallState> {
        self.walls.iter().find(|w| w.wall == name)
    }
}

/// What a node measured of its last frames.
#[derive(Serialize, Deserialize, Debug, Clone, Copy, PartialEq, Default)]
pub struct NodeStats {
    /// Drawing its eyes (GPU work and read-back), microseconds.
    pub draw_us: u32,
    /// Samples inserted into its render cache for this frame.
    pub samples: u32,
    /// Frames it has presented since it started.
    pub presented: u64,
    /// Frames it skipped because a newer one had arrived (it was late).
    pub skipped: u64,
}

/// Master → node.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub enum MasterMsg {
    Frame(FrameState),
    /// Show the frame (every node that was ready for it gets the same Swap).
    Swap {
        frame: u64,
    },
    /// The cluster is stopping; the node exits.
    Shutdown {
        reason: String,
    },
}

/// Node → master.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub enum NodeMsg {
    /// The frame is drawn and waits for Swap.
    Ready { frame: u64, stats: NodeStats },
    /// The node is going away (its window was closed): no longer wait for it.
    Leaving { reason: String },
}
