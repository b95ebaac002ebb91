//! A session's glare, frame by frame and eye by eye: each frame's views (each eye and the
//! head's gaze in scene coordinates, as the frame state placed them) measured by one
//! [`GlareMeter`], the figures written in frame order to a CSV ([`GlareLog`]) and summed
//! up. The frames are measured in parallel after the session, so measuring changes nothing
//! a wall shows.

use std::path::Path;

use glam::{DMat4, DVec3, Vec3};
use holocave_protocol::cluster::{FrameState, MAX_CLUSTER_FRAME, MasterMsg, WireEye};
use holocave_protocol::frame::{FrameError, read_frame};
use rayon::prelude::*;

use crate::error::GlareError;
use crate::log::{GlareLog, Summary};
use crate::meter::GlareMeter;

/// What the viewer saw at one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameView {
    pub frame: u64,
    /// When the frame was shown (ns on the session's clock).
    pub time_ns: u64,
    /// Which eye (`left`, `right`, or `centre` for a mono wall).
    pub eye_name: &'static str,
    /// The eye, scene coordinates.
    pub eye: Vec3,
    /// The gaze: the head's forward direction, scene coordinates.
    pub look: Vec3,
}

/// The head's gaze in scene coordinates: its forward direction (−Z in the head's frame,
/// turned by `orientation` in the room) through the room → scene transform.
pub fn gaze(room_to_scene: &DMat4, orientation: glam::DQuat) -> Vec3 {
    room_to_scene
        .transform_vector3(orientation * DVec3::NEG_Z)
        .as_vec3()
        .normalize_or_zero()
}

/// One frame's views as a standalone wall shows them: each of `eyes` (its name and
/// position, scene coordinates) looking where the head, turned by `orientation` in the
/// room, looks.
pub fn views_at(
    frame: u64,
    time_ns: u64,
    room_to_scene: &DMat4,
    orientation: glam::DQuat,
    eyes: impl IntoIterator<Item = (&'static str, Vec3)>,
) -> Vec<FrameView> {
    let look = gaze(room_to_scene, orientation);
    (eyes.into_iter())
        .map(|(eye_name, eye)| FrameView {
            frame,
            time_ns,
            eye_name,
            eye,
            look,
        })
        .collect()
}

/// A frame state's views: each eye of its first wall (every wall has the same eyes),
/// looking where the head looks, in scene coordinates.
pub fn views_of(state: &FrameState) -> Vec<FrameView> {
    let Some(wall) = state.walls.first() else {
        return Vec::new();
    };
    let nav = DMat4::from_cols_array(&state.navigation);
    let look = gaze(
        &nav,
        glam::Quat::from_array(state.head.orientation).as_dquat(),
    );
    wall.eyes
        .iter()
        .map(|e| FrameView {
            frame: state.frame,
            time_ns: state.display_time_ns,
            eye_name: match e.eye {
                WireEye::Left => "left",
                WireEye::Right => "right",
                WireEye::Centre => "centre",
            },
            eye: DVec3::from(e.position).as_vec3(),
            look,
        })
        .collect()
}

/// Every frame state's views (each eye) at the time of day `when` (as the frame states
/// write it; `None`: frames that carry none), read from the master's log of frame states
/// (`states.bin`), and how many frames were at another time.
pub fn views_in_states_log(
    states: &Path,
    when: Option<&str>,
) -> Result<(Vec<FrameView>, usize), GlareError> {
    let failed = |message: String| GlareError::StatesLog {
        path: states.to_owned(),
        message,
    };
    let file = std::fs::File::open(states).map_err(|e| failed(e.to_string()))?;
    let mut r = std::io::BufReader::new(file);
    let (mut views, mut other_times) = (Vec::new(), 0);
    loop {
        match read_frame::<_, MasterMsg>(&mut r, MAX_CLUSTER_FRAME) {
            Ok(MasterMsg::Frame(f)) if f.when.as_deref() != when => other_times += 1,
            Ok(MasterMsg::Frame(f)) => views.extend(views_of(&f)),
            Ok(_) => {}
            Err(FrameError::Closed) => break,
            Err(e) => return Err(failed(e.to_string())),
        }
    }
    Ok((views, other_times))
}

/// A session's glare from the master's log of frame states (`states.bin`): every frame's
/// views at the time of day `when` measured with `meter` and written to `csv`; the
/// summary, the views measured, and the frames left out at another time.
pub fn measure_states_log(
    meter: &GlareMeter,
    states: &Path,
    when: Option<&str>,
    csv: &Path,
) -> Result<(Summary, usize, usize), GlareError> {
    let (views, other_times) = views_in_states_log(states, when)?;
    let summary = measure_session(meter, &views, csv)?;
    Ok((summary, views.len(), other_times))
}

/// Measures every view with `meter` and writes the figures to `csv` (the views of one
/// frame, one per eye, follow each other); the session's summary.
pub fn measure_session(
    meter: &GlareMeter,
    views: &[FrameView],
    csv: &Path,
) -> Result<Summary, GlareError> {
    let figures: Vec<_> = views
        .par_iter()
        .map(|v| meter.measure(v.eye, v.look))
        .collect::<Result<_, _>>()?;
    let mut log = GlareLog::create(csv)?;
    let mut i = 0;
    while i < views.len() {
        let frame = views[i].frame;
        let n = views[i..].iter().take_while(|v| v.frame == frame).count();
        let eyes: Vec<(&str, &_)> = (i..i + n)
            .map(|k| (views[k].eye_name, &figures[k]))
            .collect();
        log.record(frame, views[i].time_ns, &eyes)?;
        i += n;
    }
    Ok(log.finish()?.1)
}
