//! Head tracking for holocave: tracker sources (a VRPN client speaking VRPN's wire
//! protocol, CSV and `.vrpn` log replay, synthetic motions), recording, a guard against
//! bad samples, quaternion hemisphere continuity, One Euro filtering, constant-velocity
//! and double-exponential-smoothing prediction, and their offline evaluation.
//!
//! Poses are position (metres) + unit quaternion `(x, y, z, w)`; time is `u64` ns.

pub mod csv_log;
pub mod eval;
pub mod guard;
pub mod hemisphere;
pub mod input;
pub mod input_source;
pub mod one_euro;
pub mod params;
pub mod pipeline;
pub mod pose;
pub mod predict;
pub mod record;
pub mod rotation;
pub mod scripted;
pub mod session_log;
pub mod source;
pub mod synthetic;
pub mod vrpn;
pub mod vrpn_input;
pub mod vrpn_log;
pub mod vrpn_wire;

pub use params::TrackingParams;
pub use pipeline::HeadTracker;
pub use pose::{Pose, Sample};
