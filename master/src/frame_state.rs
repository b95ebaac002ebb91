//! The frame's state as the master sends it: the predicted head pose and every wall's eye
//! views (scene coordinates), from [`CaveFrusta`].

use holocave_protocol::cluster::{EyeState, FrameState, WallState, WireEye, WireObject, WirePose};
use holocave_tracking::Pose;

use holocave_cave::Cave;
use holocave_cave::{CaveFrusta, Eye};

/// Times of a frame on the master's clock (ns).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameTimes {
    pub master_ns: u64,
    pub display_ns: u64,
    /// Arrival of the newest tracker sample the pose rests on.
    pub tracker_ns: Option<u64>,
}

fn wire_eye(e: Eye) -> WireEye {
    match e {
        Eye::Left => WireEye::Left,
        Eye::Right => WireEye::Right,
        Eye::Centre => WireEye::Centre,
    }
}

/// What a frame shows besides the views: the moving objects where they are at its display
/// time, and the scene's time of day.
#[derive(Clone, Debug, Default)]
pub struct FrameWorld {
    pub objects: Vec<WireObject>,
    pub when: Option<String>,
}

/// Frame `frame`'s state from the current frusta (already updated for `head`).
pub fn frame_state(
    cave: &Cave,
    frusta: &CaveFrusta,
    frame: u64,
    times: FrameTimes,
    head: &Pose,
    world: FrameWorld,
) -> FrameState {
    let walls = cave
        .walls
        .iter()
        .zip(&frusta.walls)
        .map(|(wall, views)| WallState {
            wall: wall.name.clone(),
            eyes: views
                .eyes
                .iter()
                .map(|&(eye, f)| EyeState {
                    eye: wire_eye(eye),
                    position: cave.room_to_scene.transform_point3(f.eye).to_array(),
                    view: f.view.to_cols_array(),
                    proj: f.proj.to_cols_array(),
                    near: f.near,
                })
                .collect(),
        })
        .collect();
    FrameState {
        frame,
        master_time_ns: times.master_ns,
        display_time_ns: times.display_ns,
        tracker_time_ns: times.tracker_ns,
        head: WirePose {
            position: head.position.to_array(),
            orientation: head.orientation.to_array(),
        },
        walls,
        navigation: cave.room_to_scene.to_cols_array(),
        objects: world.objects,
        when: world.when,
    }
}
