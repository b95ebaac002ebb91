//! What the render node's benches share: the two eyes of a 3 m wall seen from 1.5 m.

use glam::Vec3;
use holocave_cave::WallView;
use holocave_render_node::EyeView;

/// Both eyes (6.4 cm apart) of a 3 × 3 m wall 1.5 m ahead, at `w × h` pixels each.
pub fn views(w: u32, h: u32) -> Vec<EyeView> {
    [-0.032f32, 0.032]
        .iter()
        .map(|&dx| {
            EyeView::looking_at(
                WallView {
                    eye: Vec3::new(dx, 1.5, 0.0),
                    pa: Vec3::new(-1.5, 0.0, -1.5),
                    pb: Vec3::new(1.5, 0.0, -1.5),
                    pc: Vec3::new(-1.5, 3.0, -1.5),
                    width: w,
                    height: h,
                },
                0.05,
            )
            .expect("the eye is in front of the wall")
        })
        .collect()
}
