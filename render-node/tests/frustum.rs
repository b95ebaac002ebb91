//! The render cache's Kooima projection (`EyeView::kooima`) and the master's frusta
//! (`holocave_master::frustum::off_axis`) put every point on the same pixel at the same
//! depth, for every wall of the CAVE and both eyes, with a navigation transform.

use glam::{DVec3, Vec3};
use holocave_master::frustum::{Eye, eye_position, off_axis};
use holocave_master::load_cave;
use holocave_render_node::EyeView;
use holocave_tracer::view::WallView;
use holocave_tracking::Pose;

#[test]
fn kooima_matches_the_master_frusta() {
    let root = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let cave = load_cave(&root.join("configs/cave4-cornell.toml")).expect("load the config");
    let head = Pose::new(Vec3::new(0.2, 1.6, 0.3), glam::Quat::from_rotation_y(0.3));
    let to_scene = cave.room_to_scene;
    let sp = |p: DVec3| to_scene.transform_point3(p).as_vec3();
    for wall in &cave.walls {
        for eye in [Eye::Left, Eye::Right] {
            let e = eye_position(&cave, &head, eye);
            let f = off_axis(wall, e, cave.near, &to_scene).expect("a frustum");
            let mine = EyeView::kooima(
                WallView {
                    eye: sp(e),
                    pa: sp(wall.pa),
                    pb: sp(wall.pb),
                    pc: sp(wall.pc),
                    width: 64,
                    height: 48,
                },
                f.near as f32,
            );
            let master = EyeView {
                view_proj: f.view_proj().as_mat4(),
                ..mine
            };
            for k in 0..50 {
                let t = k as f32 / 50.0;
                // Points in front of the wall, seen from the eye, spread over its area.
                let on_wall = sp(wall.pa
                    + (wall.pb - wall.pa) * f64::from(t)
                    + (wall.pc - wall.pa) * f64::from((t * 7.0).fract()));
                let p = mine.eye() + (on_wall - mine.eye()) * (1.5 + t);
                let a = mine.project(p).expect("in front");
                let b = master.project(p).expect("in front");
                assert!(
                    (a.0 - b.0).abs() < 1e-2 && (a.1 - b.1).abs() < 1e-2,
                    "wall {} {eye:?}: {a:?} vs {b:?}",
                    wall.name
                );
                assert!((a.2 - b.2).abs() < 1e-4 * a.2.max(1.0));
            }
        }
    }
}
