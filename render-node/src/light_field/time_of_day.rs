//! A wall lit for another time of day than the one its node started at. The master's
//! frames carry the session's time ([`FrameState::when`](holocave_protocol::cluster::FrameState)),
//! stepped by keys or set by a replayed log; a node whose display is lit for another time
//! makes it again, lit for the frame's time, before drawing that frame:
//!
//! - the scene's sun and sky at that time (its daylight file, site and weather hour read
//!   again): the direct light per pixel follows at once;
//! - the light field of that time: with a bake set (a folder, [`holocave_vlf::hours`]) the
//!   two bakes around it blended; a single bake's indirect light stays that of its own time;
//! - its samples from its own tracer at that time: a holodeck's samples hold the light of
//!   the session's start, so the wall leaves them until the time comes back to it.

use std::sync::Arc;

use holocave_scene::Scene;
use holocave_scene::daylight::{Daylight, When};

/// The scene's daylight at a time (its daylight file and weather read for it).
pub type DaylightAt = Arc<dyn Fn(When) -> Result<Daylight, String> + Send + Sync>;

/// How a node lights its scene for a time of day.
#[derive(Clone)]
pub struct TimeOfDay {
    /// The time the node's scene was loaded at: the session's start.
    pub start: When,
    pub daylight_at: DaylightAt,
}

impl TimeOfDay {
    /// The frame's time of day `when` when it is another than the start's (`None`: the
    /// start's, or no time). A time that does not parse is logged and taken as the start.
    pub fn other_time(&self, when: Option<&str>) -> Option<When> {
        let w = when?;
        match w.parse::<When>() {
            Ok(w) if w != self.start => Some(w),
            Ok(_) => None,
            Err(e) => {
                tracing::warn!("the master's time of day: {e}; drawn at {}", self.start);
                None
            }
        }
    }

    /// `scene` lit for `when`.
    pub fn scene_at(&self, scene: &Scene, when: When) -> Result<Scene, String> {
        Ok(scene.with_daylight((self.daylight_at)(when)?))
    }
}
