//! Each mode against its analytic motion, collisions and floor following against scenes
//! made of a few quads, and replay of a session log.

use std::path::Path;

use glam::{DMat4, DQuat, DVec3, Quat, Vec2, Vec3};
use holocave_cave::{Navigation, TravelMode};
use holocave_scene::{Material, Scene, SceneParts, TriangleShading};
use holocave_tracking::Pose;

use super::input::{InputState, WandPose};
use super::{Navigator, Placement};

const DT: f64 = 1.0 / 60.0;

/// A quad `o, o + a, o + a + b, o + b` as two triangles.
fn quad(o: Vec3, a: Vec3, b: Vec3) -> [[Vec3; 3]; 2] {
    [[o, o + a, o + a + b], [o, o + a + b, o + b]]
}

fn scene(quads: &[[[Vec3; 3]; 2]]) -> Scene {
    let mut parts = SceneParts {
        name: "navigation test".into(),
        materials: vec![Material::default()],
        ..SceneParts::default()
    };
    for t in quads.iter().flatten() {
        parts.positions.push(*t);
        parts.shading.push(TriangleShading {
            normals: None,
            uvs: [Vec2::ZERO; 3],
            material: 0,
        });
    }
    Scene::from_parts(parts, Path::new("<navigation test>")).unwrap()
}

/// A floor at height `y` over x in ±20, z from `z0` to `z1`.
fn floor(y: f32, z0: f32, z1: f32) -> [[Vec3; 3]; 2] {
    quad(
        Vec3::new(-20.0, y, z1),
        Vec3::new(40.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, z0 - z1),
    )
}

/// A wall across the room at `z`, facing +Z, up to `h`, from height `y0`.
fn wall(z: f32, y0: f32, h: f32) -> [[Vec3; 3]; 2] {
    quad(
        Vec3::new(-20.0, y0, z),
        Vec3::new(40.0, 0.0, 0.0),
        Vec3::new(0.0, h, 0.0),
    )
}

fn settings(mode: TravelMode) -> Navigation {
    Navigation {
        mode,
        ..Navigation::default()
    }
}

fn head() -> Pose {
    Pose::new(Vec3::new(0.0, 1.6, 0.0), Quat::IDENTITY)
}

/// A wand at `position` pointing along yaw `yaw` (rad, counter-clockwise from −Z seen from
/// above) and pitch `pitch` (rad, up positive).
fn wand(position: DVec3, yaw: f64, pitch: f64) -> WandPose {
    WandPose {
        position,
        orientation: DQuat::from_rotation_y(yaw) * DQuat::from_rotation_x(pitch),
    }
}

fn joystick(forward: f64, turn: f64, w: Option<WandPose>) -> InputState {
    InputState {
        wand: w,
        axes: vec![turn, forward],
        ..InputState::default()
    }
}

/// The head's place in the scene.
fn head_in_scene(p: &Placement) -> DVec3 {
    p.point(head().position.as_dvec3())
}

fn feet_in_scene(p: &Placement) -> DVec3 {
    p.point(DVec3::ZERO)
}

#[test]
fn walking_moves_speed_times_time_along_the_wands_horizontal_heading() {
    // The room turned 90° in the scene, the wand 30° left and 20° down: the walk is along
    // the wand's horizontal heading, turned with the room, at 1.4 m/s.
    let start = DMat4::from_rotation_translation(
        DQuat::from_rotation_y(std::f64::consts::FRAC_PI_2),
        DVec3::new(3.0, 0.0, -2.0),
    );
    let mut nav = Navigator::new(settings(TravelMode::Walk), &start);
    let w = wand(
        DVec3::new(0.2, 1.2, -0.3),
        30f64.to_radians(),
        -20f64.to_radians(),
    );
    let before = head_in_scene(&nav.placement());
    let frames = 150; // 2.5 s
    for _ in 0..frames {
        nav.step(&head(), &joystick(1.0, 0.0, Some(w)), DT, None);
    }
    let moved = head_in_scene(&nav.placement()) - before;
    let t = frames as f64 * DT;
    let yaw = 30f64.to_radians() + std::f64::consts::FRAC_PI_2;
    let heading = DVec3::new(-yaw.sin(), 0.0, -yaw.cos());
    let expected = heading * 1.4 * t;
    // f64 sums of 150 steps: a few ulps of 3.5 m each.
    assert!(
        (moved - expected).length() < 1e-12,
        "moved {moved}, expected {expected}"
    );
    // Half deflection past the dead zone: half the speed (shaped: (0.55 − 0.1) / 0.9).
    let mut nav = Navigator::new(settings(TravelMode::Walk), &DMat4::IDENTITY);
    for _ in 0..60 {
        nav.step(&head(), &joystick(0.55, 0.0, Some(w)), DT, None);
    }
    let moved = head_in_scene(&nav.placement()) - head().position.as_dvec3();
    assert!((moved.length() - 0.7).abs() < 1e-12, "{}", moved.length());
}

#[test]
fn turning_is_the_configured_rate_about_the_heads_vertical() {
    let mut nav = Navigator::new(settings(TravelMode::Walk), &DMat4::IDENTITY);
    let h = Pose::new(Vec3::new(0.7, 1.6, -0.4), Quat::IDENTITY);
    let pivot = h.position.as_dvec3();
    let frames = 90; // 1.5 s at 45°/s: 67.5° to the right
    for _ in 0..frames {
        nav.step(&h, &joystick(0.0, 1.0, None), DT, None);
    }
    let p = nav.placement();
    let (axis, angle) = p.rotation.to_axis_angle();
    let expected = 45f64.to_radians() * frames as f64 * DT;
    assert!(
        (angle - expected).abs() < 1e-12 && (axis - DVec3::NEG_Y).length() < 1e-12,
        "turned {angle} about {axis}, expected {expected} about −Y (to the right)"
    );
    assert!(
        (p.point(pivot) - pivot).length() < 1e-12,
        "the head stays put"
    );
    // Turning right: the room's forward (−Z) now points right of the scene's −Z (+X side).
    assert!(p.dir(DVec3::NEG_Z).x > 0.0);
}

#[test]
fn grabbing_moves_the_world_by_the_wands_motion_while_held_and_not_after() {
    for yaw_only in [true, false] {
        let mut s = settings(TravelMode::Walk);
        s.grab_yaw_only = yaw_only;
        let mut nav = Navigator::new(s, &DMat4::from_translation(DVec3::new(1.0, 0.0, 2.0)));
        let held = |w: WandPose, down: bool| InputState {
            wand: Some(w),
            buttons: vec![down],
            presses: vec![0],
            axes: vec![],
            ..InputState::default()
        };
        let at = |k: usize| {
            let k = k as f64;
            wand(
                DVec3::new(0.1 * k, 1.0 + 0.02 * k, -0.05 * k),
                0.05 * k,
                if yaw_only { 0.0 } else { 0.03 * k },
            )
        };
        // Frames 0..3 released, the wand moving: nothing moves.
        for k in 0..3 {
            nav.step(&head(), &held(at(k), false), DT, None);
        }
        assert_eq!(nav.placement().translation, DVec3::new(1.0, 0.0, 2.0));
        // Pressed at frame 3, held to frame 10: the scene point at the wand on frame 3
        // stays at the wand, and every room point moves with the wand's motion.
        nav.step(&head(), &held(at(3), true), DT, None);
        let grabbed = nav.placement();
        assert_eq!(
            grabbed.translation,
            DVec3::new(1.0, 0.0, 2.0),
            "the press itself moves nothing (the motion before it is not grabbed)"
        );
        let pinned = grabbed.point(at(3).position);
        for k in 4..=10 {
            nav.step(&head(), &held(at(k), true), DT, None);
        }
        let p = nav.placement();
        assert!(
            (p.point(at(10).position) - pinned).length() < 1e-12,
            "yaw_only {yaw_only}: the grabbed point left the wand"
        );
        let d_q = at(10).orientation * at(3).orientation.inverse();
        let r = DVec3::new(-0.4, 0.3, 0.9);
        let moved_r = d_q * (r - at(3).position) + at(10).position;
        assert!(
            (p.point(moved_r) - grabbed.point(r)).length() < 1e-12,
            "the world moves by exactly the wand's motion"
        );
        // Released: the wand goes on moving, the world stays.
        for k in 11..15 {
            nav.step(&head(), &held(at(k), false), DT, None);
        }
        assert_eq!(nav.placement(), p);
    }
    // Yaw only, with a wand that pitches and rolls: the world stays upright.
    yaw_only_keeps_the_world_upright();
}

/// Pulling the world by the wand towards a wall stops the body a radius short of it, as
/// walking does; without a scene the grab goes on through.
#[test]
fn grabbing_the_world_does_not_pull_the_body_through_a_wall() {
    let sc = scene(&[floor(0.0, -40.0, 40.0), wall(-3.0, 0.0, 3.0)]);
    let held = |w: WandPose| InputState {
        wand: Some(w),
        buttons: vec![true],
        presses: vec![0],
        axes: vec![],
        ..InputState::default()
    };
    for with_scene in [true, false] {
        let mut nav = Navigator::new(settings(TravelMode::Walk), &DMat4::IDENTITY);
        // The wand pulled towards the user (+Z) 10 cm a frame: the world comes along, the
        // user goes −Z in the scene, towards the wall at z = −3.
        for k in 0..60 {
            let w = wand(DVec3::new(0.0, 1.0, -0.5 + 0.1 * k as f64), 0.0, 0.0);
            nav.step(&head(), &held(w), DT, with_scene.then_some(&sc));
        }
        let z = nav.placement().point(head().position.as_dvec3()).z;
        if with_scene {
            let r = nav.settings().radius;
            assert!((z - (-3.0 + r)).abs() < 1e-9, "stopped at z = {z}");
        } else {
            assert!(z < -5.0, "without a scene the grab goes on: z = {z}");
        }
    }
}

fn yaw_only_keeps_the_world_upright() {
    let mut nav = Navigator::new(settings(TravelMode::Walk), &DMat4::IDENTITY);
    for k in 0..10 {
        let w = WandPose {
            position: DVec3::new(0.0, 1.0, 0.0),
            orientation: DQuat::from_rotation_x(0.1 * k as f64)
                * DQuat::from_rotation_z(0.07 * k as f64),
        };
        let input = InputState {
            wand: Some(w),
            buttons: vec![true],
            presses: vec![0],
            axes: vec![],
            ..InputState::default()
        };
        nav.step(&head(), &input, DT, None);
    }
    let up = nav.placement().dir(DVec3::Y);
    assert!((up - DVec3::Y).length() < 1e-12, "the room's up is {up}");
}

#[test]
fn flying_goes_along_the_wand_up_and_down_included() {
    let mut nav = Navigator::new(settings(TravelMode::Fly), &DMat4::IDENTITY);
    let w = wand(
        DVec3::new(0.0, 1.2, 0.0),
        -40f64.to_radians(),
        25f64.to_radians(),
    );
    for _ in 0..120 {
        nav.step(&head(), &joystick(1.0, 0.0, Some(w)), DT, None);
    }
    let moved = head_in_scene(&nav.placement()) - head().position.as_dvec3();
    let expected = w.forward() * 3.0 * 2.0;
    assert!((moved - expected).length() < 1e-12, "{moved} vs {expected}");
    assert!(moved.y > 2.0, "no gravity: it climbed {}", moved.y);
}

#[test]
fn walking_into_a_wall_stops_at_the_radius() {
    // Floor at 0, a wall at z = −5 facing the user; 10 s of full forward (14 m wanted).
    let sc = scene(&[floor(0.0, -10.0, 10.0), wall(-5.0, 0.0, 3.0)]);
    let s = settings(TravelMode::Walk);
    let radius = s.radius;
    let mut nav = Navigator::new(s, &DMat4::IDENTITY);
    let w = wand(DVec3::new(0.0, 1.2, 0.0), 0.0, 0.0);
    for _ in 0..600 {
        nav.step(&head(), &joystick(1.0, 0.0, Some(w)), DT, Some(&sc));
    }
    let feet = feet_in_scene(&nav.placement());
    // The distance is solved in f64 on the wall's plane (its corners are f32 but exact):
    // only f64 rounding of 600 steps remains.
    assert!(
        (feet.z - (-5.0 + radius)).abs() < 1e-12,
        "feet at z = {}, expected {}",
        feet.z,
        -5.0 + radius
    );
    assert!(feet.y.abs() < 1e-12 && feet.x.abs() < 1e-12);
    // At an angle, it slides along the wall and still never comes closer than the radius.
    let mut nav = Navigator::new(settings(TravelMode::Walk), &DMat4::IDENTITY);
    let w = wand(DVec3::new(0.0, 1.2, 0.0), 40f64.to_radians(), 0.0);
    for _ in 0..600 {
        nav.step(&head(), &joystick(1.0, 0.0, Some(w)), DT, Some(&sc));
        let f = feet_in_scene(&nav.placement());
        assert!(f.z >= -5.0 + radius - 1e-12, "through the radius: {f}");
    }
    let f = feet_in_scene(&nav.placement());
    assert!(f.x < -5.0, "slid along the wall to x = {}", f.x);
}

#[test]
fn walking_follows_a_step_and_a_ramp_but_not_a_step_too_high() {
    // Floor at 0 to z = −2, a 0.2 m step to z = −4, a ramp rising 1 m over 4 m to z = −8,
    // then a 0.5 m ledge (higher than the 0.35 m step height).
    let sc = scene(&[
        floor(0.0, -2.0, 10.0),
        wall(-2.0, 0.0, 0.2),
        floor(0.2, -4.0, -2.0),
        quad(
            Vec3::new(-20.0, 0.2, -4.0),
            Vec3::new(40.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, -4.0),
        ),
        wall(-8.0, 1.2, 0.5),
        floor(1.7, -20.0, -8.0),
    ]);
    let s = settings(TravelMode::Walk);
    let radius = s.radius;
    let mut nav = Navigator::new(s, &DMat4::IDENTITY);
    let w = wand(DVec3::new(0.0, 1.2, 0.0), 0.0, 0.0);
    let ground = |z: f64| {
        if z > -2.0 {
            0.0
        } else if z > -4.0 {
            0.2
        } else {
            0.2 + (-4.0 - z) / 4.0
        }
    };
    let mut last = DVec3::ZERO;
    for _ in 0..600 {
        nav.step(&head(), &joystick(1.0, 0.0, Some(w)), DT, Some(&sc));
        let f = feet_in_scene(&nav.placement());
        // On the floor wherever it is: solved in f64 on planes whose corners are f32
        // (0.2 and 1.2 m are 3e-9 and 5e-8 m off in f32).
        assert!(
            (f.y - ground(f.z)).abs() < 1e-6,
            "feet at height {} over z = {}, the floor is at {}",
            f.y,
            f.z,
            ground(f.z)
        );
        last = f;
    }
    // The 0.5 m ledge at z = −8 stops the user at the radius on the ramp.
    assert!(
        (last.z - (-8.0 + radius)).abs() < 1e-4,
        "stopped at z = {}",
        last.z
    );
}

#[test]
fn teleport_stands_the_user_on_the_floor_where_the_wand_points() {
    let sc = scene(&[
        floor(0.0, -20.0, 20.0),
        floor(0.5, -12.0, -6.0),
        wall(-15.0, 0.0, 3.0),
    ]);
    let mut nav = Navigator::new(settings(TravelMode::Walk), &DMat4::IDENTITY);
    // A wand at 1 m pointing 45° down: the floor at 1 m ahead.
    let w = wand(DVec3::new(0.0, 1.0, 0.0), 0.0, -45f64.to_radians());
    let press = |w| InputState {
        wand: Some(w),
        buttons: vec![false, true],
        presses: vec![0, 1],
        axes: vec![],
        ..InputState::default()
    };
    nav.step(&head(), &press(w), DT, Some(&sc));
    let f = feet_in_scene(&nav.placement());
    assert!((f - DVec3::new(0.0, 0.0, -1.0)).length() < 1e-9, "{f}");
    // Pointing slightly down (−5°) from 1 m: the raised floor at 0.5 m height is hit
    // (1 − 0.5) / tan 5° ahead of the wand.
    let w2 = wand(DVec3::new(0.0, 1.0, 0.0), 0.0, -5f64.to_radians());
    let before = nav.placement().point(w2.position);
    nav.step(&head(), &press(w2), DT, Some(&sc));
    let f = feet_in_scene(&nav.placement());
    let ahead = 0.5 / 5f64.to_radians().tan();
    assert!(
        (f - DVec3::new(0.0, 0.5, before.z - ahead)).length() < 1e-9,
        "{f}, expected z = {}",
        before.z - ahead
    );
    // Held, not pressed again: nothing more happens.
    let held = InputState {
        presses: vec![0, 0],
        ..press(w2)
    };
    let p = nav.placement();
    nav.step(&head(), &held, DT, Some(&sc));
    assert_eq!(nav.placement(), p);
}

/// The master keeps the frusta in room coordinates when navigating and places each frame's
/// views in the scene afterwards (`view · navigation⁻¹`): that is the very product the
/// projection computes with the navigation inside, bit for bit, so the frame states are
/// the same as if every frustum were computed in the scene.
#[test]
fn frusta_placed_after_the_fact_equal_frusta_computed_in_the_scene() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../configs/cave4.toml"
    ))
    .unwrap();
    let cave = holocave_cave::parse_cave(&text, "cave4.toml").unwrap();
    let nav = DMat4::from_rotation_translation(
        DQuat::from_rotation_y(2.1) * DQuat::from_rotation_x(0.1),
        DVec3::new(12.5, -0.3, -40.25),
    );
    let eye = DVec3::new(0.3, 1.55, -0.2);
    for wall in &cave.walls {
        let direct = holocave_cave::off_axis(wall, eye, cave.near, &nav).unwrap();
        let room = holocave_cave::off_axis(wall, eye, cave.near, &DMat4::IDENTITY).unwrap();
        assert_eq!(
            (room.view * nav.inverse()).to_cols_array(),
            direct.view.to_cols_array(),
            "wall {}",
            wall.name
        );
        assert_eq!(room.proj, direct.proj);
    }
}

mod desk {
    use std::sync::Arc;

    use holocave_protocol::cluster::DeskInput;

    use super::*;
    use crate::head::Clock;
    use crate::navigation::desk::Desk;
    use crate::navigation::input::Inputs;
    use crate::navigation::run::{Devices, NavigationRun};

    const PERIOD_NS: u64 = 16_666_667;

    fn desk(forward: f32, turn: f32, teleport: bool) -> DeskInput {
        DeskInput {
            forward,
            turn,
            teleport,
            ..DeskInput::NEUTRAL
        }
    }

    /// A desk walk: ahead, ahead turning right, back turning left, a teleport tap, ahead.
    fn script() -> Vec<DeskInput> {
        let mut s = Vec::new();
        s.extend(std::iter::repeat_n(desk(1.0, 0.0, false), 30));
        s.extend(std::iter::repeat_n(desk(1.0, 1.0, false), 30));
        s.extend(std::iter::repeat_n(desk(-1.0, -1.0, false), 20));
        s.push(desk(0.0, 0.0, true));
        s.extend(std::iter::repeat_n(desk(0.5, 0.0, false), 20));
        s
    }

    /// The script with the walk/fly key pressed for a frame after the turns: the rest
    /// flies.
    fn script_with_mode() -> Vec<DeskInput> {
        let mut s = script();
        s.insert(
            80,
            DeskInput {
                mode: true,
                ..DeskInput::NEUTRAL
            },
        );
        s
    }

    fn room() -> Arc<Scene> {
        Arc::new(scene(&[floor(0.0, -40.0, 40.0), wall(-6.0, 0.0, 3.0)]))
    }

    /// Non-default channels and signs, so the mapping onto them is exercised.
    fn odd_settings() -> Navigation {
        Navigation {
            forward_axis: 3,
            turn_axis: 1,
            forward_sign: -1.0,
            turn_sign: -1.0,
            teleport_button: Some(2),
            ..settings(TravelMode::Walk)
        }
    }

    fn run_of(s: &Navigation, inputs: Inputs, sc: &Arc<Scene>) -> NavigationRun {
        NavigationRun::new(
            Navigator::new(s.clone(), &DMat4::IDENTITY),
            inputs,
            Some(sc.clone()),
        )
    }

    fn no_devices() -> Inputs {
        Inputs::new(Clock::Replay, None, None, None, DMat4::IDENTITY)
    }

    #[test]
    fn a_desk_stream_moves_exactly_as_the_joystick_and_buttons_do() {
        let s = odd_settings();
        let sc = room();
        let mut by_desk = run_of(&s, no_devices(), &sc);
        by_desk.desk = Some(Desk::default());
        let mut by_joystick = Navigator::new(s.clone(), &DMat4::IDENTITY);
        let mut teleported = false;
        for (i, d) in script().into_iter().enumerate() {
            // The teleport is a tap shorter than a frame: down and up before the frame.
            by_desk.desk_message(7, Some(d));
            if d.teleport {
                by_desk.desk_message(7, Some(desk(0.0, 0.0, false)));
            }
            let a = by_desk.frame(i as u64 * PERIOD_NS, &head(), Vec3::ZERO);
            // The same travel from a joystick whose forward and right are negative.
            let mut axes = vec![0.0; 4];
            axes[3] = -f64::from(d.forward);
            axes[1] = -f64::from(d.turn);
            let state = InputState {
                wand: None,
                buttons: vec![false; 3],
                presses: vec![0, 0, u32::from(d.teleport)],
                axes,
                ..InputState::default()
            };
            let dt = if i == 0 { 0.0 } else { PERIOD_NS as f64 * 1e-9 };
            let b = by_joystick.step(&head(), &state, dt, Some(&sc));
            assert_eq!(a, b, "frame {i}");
            if d.teleport {
                teleported = true;
                // Aimed with the head (no wand): at the wall's foot, a radius back.
                let p = head_in_scene(&a);
                assert!(p.z < -4.0, "teleported to {p}");
            }
        }
        assert!(teleported);
    }

    #[test]
    fn desk_csv_replays_the_desk_walk_bit_for_bit() {
        let s = odd_settings();
        let sc = room();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("desk.csv");
        let mut live = run_of(&s, no_devices(), &sc);
        live.desk = Some(Desk::default());
        live.log_desk(&path).unwrap();
        let mut first = Vec::new();
        for (i, d) in script_with_mode().into_iter().enumerate() {
            live.desk_message(3, Some(d));
            if d.teleport {
                live.desk_message(3, Some(desk(0.0, 0.0, false)));
            }
            first.push(live.frame(i as u64 * PERIOD_NS, &head(), Vec3::ZERO));
        }
        live.finish().unwrap();

        let spec = format!("file:{}", path.display());
        let devices = Devices {
            buttons: Some(spec.clone()),
            axes: Some(spec),
            ..Devices::default()
        };
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../configs/cave4.toml"
        ))
        .unwrap();
        let mut cave = holocave_cave::parse_cave(&text, "cave4.toml").unwrap();
        cave.navigation = s;
        cave.room_to_scene = DMat4::IDENTITY;
        cave.tracker_to_room = DMat4::IDENTITY;
        let mut replay = NavigationRun::open(&cave, &devices, Clock::Replay, Some(sc))
            .unwrap()
            .unwrap();
        for (i, a) in first.iter().enumerate() {
            let b = replay.frame(i as u64 * PERIOD_NS, &head(), Vec3::ZERO);
            assert_eq!(*a, b, "frame {i}");
        }
        // The key was replayed too: both runs fly at the end.
        assert_eq!(live.navigator.settings().mode, TravelMode::Fly);
        assert_eq!(replay.navigator.settings().mode, TravelMode::Fly);
    }

    #[test]
    fn garbage_is_dropped_and_a_node_that_leaves_releases_its_keys() {
        let s = settings(TravelMode::Walk);
        let mut d = Desk::default();
        let nan = DeskInput {
            forward: f32::NAN,
            ..DeskInput::NEUTRAL
        };
        assert!(d.receive(&s, 1, nan).unwrap_err().contains("forward"));
        assert_eq!(d.merged(), DeskInput::NEUTRAL);
        d.receive(&s, 2, desk(0.0, 1.0, false)).unwrap();
        d.receive(&s, 1, desk(1.0, -1.0, false)).unwrap();
        // Axes: the first non-neutral node by id; node 1 turns left, node 2 right.
        assert_eq!((d.merged().forward, d.merged().turn), (1.0, -1.0));
        d.forget(&s, 1);
        assert_eq!((d.merged().forward, d.merged().turn), (0.0, 1.0));
        d.forget(&s, 2);
        let (state, _) = d.take();
        assert_eq!((state.axis(0), state.axis(1)), (0.0, 0.0));
    }

    #[test]
    fn the_time_keys_step_the_time_once_and_desk_csv_replays_the_time() {
        let sc = room();
        let dir = tempfile::tempdir().unwrap();
        let desk_csv = dir.path().join("desk.csv");
        let mut run = run_of(&settings(TravelMode::Walk), no_devices(), &sc);
        run.desk = Some(Desk::default());
        run.log_desk(&desk_csv).unwrap();
        let mut sun = crate::sun_clock::SunClock::new("2026-12-21T09:00".parse().unwrap());
        let step = |m| DeskInput {
            time_step_min: m,
            ..DeskInput::NEUTRAL
        };
        run.desk_message(1, Some(step(60)));
        run.desk_message(2, Some(step(-15)));
        let mut times = Vec::new();
        for f in 0..3 {
            run.frame(f * PERIOD_NS, &head(), Vec3::ZERO);
            let (set, step) = run.time_input();
            if sun.advance(set, step) {
                run.log_time(f * PERIOD_NS, sun.local().unwrap());
            }
            times.push(sun.now().to_string());
        }
        assert_eq!(times, ["2026-12-21T09:45:00"; 3]);
        run.finish().unwrap();
        let log = holocave_tracking::session_log::read_session(&desk_csv).unwrap();
        let set: Vec<_> = (log.inputs.iter())
            .filter_map(|e| match &e.event {
                holocave_tracking::input::InputEvent::Time(t) => Some((e.t_ns, t.to_string())),
                _ => None,
            })
            .collect();
        assert_eq!(set, [(0, "2026-12-21 09:45:00".to_string())]);
    }

    #[test]
    fn the_wands_earlier_and_later_buttons_step_the_time_once_a_press() {
        use holocave_tracking::input::{InputEvent, InputSample};
        use holocave_tracking::input_source::InputSource;
        let s = Navigation {
            earlier_button: Some(5),
            later_button: Some(6),
            time_step_min: 30,
            ..settings(TravelMode::Walk)
        };
        let press = |t, index| {
            [true, false].map(|down| {
                InputSample::new(
                    t,
                    InputEvent::Button {
                        index,
                        pressed: down,
                    },
                )
            })
        };
        // Later twice in the first frame (a click shorter than a frame counts), earlier
        // once in the third; held buttons do not step again.
        let events: std::collections::VecDeque<_> =
            [press(1, 6), press(2, 6), press(2 * PERIOD_NS + 1, 5)]
                .concat()
                .into();
        let inputs = Inputs::new(
            Clock::Replay,
            None,
            Some(InputSource::Replay(events)),
            None,
            DMat4::IDENTITY,
        );
        let mut run = run_of(&s, inputs, &room());
        let steps: Vec<i64> = (0..4)
            .map(|f| {
                run.frame(f * PERIOD_NS + 10, &head(), Vec3::ZERO);
                run.time_input().1
            })
            .collect();
        assert_eq!(steps, [60, 0, -30, 0]);
    }

    #[test]
    fn the_mode_key_toggles_walk_and_fly_once_a_press() {
        let sc = room();
        let mut run = run_of(&settings(TravelMode::Walk), no_devices(), &sc);
        run.desk = Some(Desk::default());
        let mode = DeskInput {
            mode: true,
            ..DeskInput::NEUTRAL
        };
        run.desk_message(1, Some(mode));
        run.frame(0, &head(), Vec3::ZERO);
        assert_eq!(run.navigator.settings().mode, TravelMode::Fly);
        run.desk_message(1, Some(mode)); // held: no new press
        run.frame(PERIOD_NS, &head(), Vec3::ZERO);
        assert_eq!(run.navigator.settings().mode, TravelMode::Fly);
        run.desk_message(1, Some(DeskInput::NEUTRAL));
        run.desk_message(1, Some(mode));
        run.frame(2 * PERIOD_NS, &head(), Vec3::ZERO);
        assert_eq!(run.navigator.settings().mode, TravelMode::Walk);
    }
}
