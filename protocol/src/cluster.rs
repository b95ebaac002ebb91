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
    /// The scene's time of day this frame, as `--when` writes it (`None`: the scene has no
    /// time; every wall draws its light as loaded). Keys or a replayed session step it;
    /// a node whose light is for another time lights its wall anew.
    pub when: Option<String>,
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
    /// This frame's per-pixel light-field pass, over every eye: pixels whose surfaces
    /// were traced anew, pixels drawn again from the last frame's (a still view), and
    /// pixels that took direct-light estimates.
    pub traced: u32,
    pub reused: u32,
    pub estimated: u32,
}

/// Master → node. (Its frame variant is the large one and the common one: a message a
/// frame per node, decoded once and dropped, so boxing it would only add an allocation.)
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
#[allow(clippy::large_enum_variant)]
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
    /// Another wall's bright sources, relayed as its node sent them ([`NodeMsg::Veil`]):
    /// the head sees every wall at once, so they veil this wall too (human mode).
    Veil {
        wall: String,
        sources: Vec<VeilSource>,
    },
}

/// Node → master.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub enum NodeMsg {
    /// The frame is drawn and waits for Swap.
    Ready { frame: u64, stats: NodeStats },
    /// The node is going away (its window was closed): no longer wait for it.
    Leaving { reason: String },
    /// A desk user's keyboard and mouse in the node's window, sent when it changes; the
    /// master maps it onto its navigation inputs (the node computes nothing).
    DeskInput(DeskInput),
    /// This wall's bright sources as its human-mode tone mapping found them in the frame
    /// just drawn (at most [`MAX_VEIL_SOURCES`]); the master relays them to the other
    /// walls' nodes. Not part of any frame state: a replayed session's states stay the
    /// same whatever the nodes drew.
    Veil { sources: Vec<VeilSource> },
}

/// The most veiling sources a wall shares ([`NodeMsg::Veil`]).
pub const MAX_VEIL_SOURCES: usize = 256;

/// One bright source a wall shares for veiling glare: its unit direction from the eye
/// (scene frame) and its radiance times solid angle (RGB, the scene's units × sr).
#[derive(Serialize, Deserialize, Debug, Clone, Copy, PartialEq)]
pub struct VeilSource {
    pub dir: [f32; 3],
    pub flux: [f32; 3],
}

impl VeilSource {
    /// Whether it is a source at all: a finite unit direction and a finite, non-negative
    /// flux.
    pub fn is_valid(&self) -> bool {
        let len2: f32 = self.dir.iter().map(|c| c * c).sum();
        self.dir.iter().chain(&self.flux).all(|c| c.is_finite())
            && (len2 - 1.0).abs() < 1e-3
            && self.flux.iter().all(|&c| c >= 0.0)
    }
}

/// The navigation a desk user asks for with keys and the mouse (`node --window`): the
/// joystick's two axes and the buttons, by meaning (the master maps them onto its
/// configured channels). Fixed size, so it decodes in bounded space.
#[derive(Serialize, Deserialize, Debug, Clone, Copy, PartialEq, Default)]
pub struct DeskInput {
    /// Forward (+1) or back (−1), `-1..=1`.
    pub forward: f32,
    /// Turn right (+1) or left (−1), `-1..=1`.
    pub turn: f32,
    /// The grab button held.
    pub grab: bool,
    /// The teleport button held.
    pub teleport: bool,
    /// The walk/fly toggle held (each press toggles).
    pub mode: bool,
    /// Minutes the time of day was stepped by keys since the node's last desk input
    /// (at most [`MAX_TIME_STEP_MIN`] either way); it is added once, not held.
    pub time_step_min: i32,
}

/// The largest time step one desk input carries (a week, in minutes).
pub const MAX_TIME_STEP_MIN: i32 = 7 * 24 * 60;

impl DeskInput {
    /// Nothing pressed.
    pub const NEUTRAL: DeskInput = DeskInput {
        forward: 0.0,
        turn: 0.0,
        grab: false,
        teleport: false,
        mode: false,
        time_step_min: 0,
    };

    /// An error naming the field when an axis is not a finite number in `-1..=1`.
    pub fn validate(&self) -> Result<(), String> {
        for (name, v) in [("forward", self.forward), ("turn", self.turn)] {
            if !v.is_finite() || v.abs() > 1.0 {
                return Err(format!("desk input: {name} {v} is not a number in -1..=1"));
            }
        }
        if self.time_step_min.abs() > MAX_TIME_STEP_MIN {
            return Err(format!(
                "desk input: a time step of {} min is more than a week",
                self.time_step_min
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{FrameError, decode, encode};

    fn payload(msg: &NodeMsg) -> Vec<u8> {
        encode(msg, MAX_CLUSTER_FRAME).unwrap()[4..].to_vec()
    }

    #[test]
    fn desk_input_round_trips() {
        let d = DeskInput {
            forward: -1.0,
            turn: 0.25,
            grab: true,
            teleport: false,
            mode: true,
            time_step_min: -60,
        };
        assert!(d.validate().is_ok());
        let msg = NodeMsg::DeskInput(d);
        assert_eq!(decode::<NodeMsg>(&payload(&msg)).unwrap(), msg);
        let n = NodeMsg::DeskInput(DeskInput::NEUTRAL);
        assert_eq!(decode::<NodeMsg>(&payload(&n)).unwrap(), n);
    }

    #[test]
    fn garbage_desk_input_is_refused() {
        let good = payload(&NodeMsg::DeskInput(DeskInput::NEUTRAL));
        // Cut short, a trailing byte, a bool that is not 0 or 1 (`mode`, before the time
        // step's one byte), an unknown variant.
        let mut bad_bool = good.clone();
        let mode = bad_bool.len() - 2;
        bad_bool[mode] = 7;
        let mut long = good.clone();
        long.push(0);
        let mut variant = good.clone();
        variant[0] = 200;
        for bytes in [
            &good[..good.len() - 1],
            &long[..],
            &bad_bool[..],
            &variant[..],
        ] {
            assert!(
                matches!(decode::<NodeMsg>(bytes), Err(FrameError::Decode { .. })),
                "{bytes:?}"
            );
        }
        // Decodable but out of range: refused by name.
        for (f, t) in [
            (f32::NAN, 0.0),
            (0.0, 1.5),
            (f32::INFINITY, 0.0),
            (-2.0, 0.0),
        ] {
            let d = DeskInput {
                forward: f,
                turn: t,
                ..DeskInput::NEUTRAL
            };
            let back = decode::<NodeMsg>(&payload(&NodeMsg::DeskInput(d))).unwrap();
            let NodeMsg::DeskInput(back) = back else {
                panic!("{back:?}")
            };
            let e = back.validate().unwrap_err();
            assert!(e.contains(if f != 0.0 { "forward" } else { "turn" }), "{e}");
        }
        let leap = DeskInput {
            time_step_min: -MAX_TIME_STEP_MIN - 1,
            ..DeskInput::NEUTRAL
        };
        let e = leap.validate().unwrap_err();
        assert!(e.contains("time step of -10081 min"), "{e}");
    }
}
