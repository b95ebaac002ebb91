//! What the render node's benches share: the two eyes of a 3 m wall seen from 1.5 m.

use glam::Vec3;
use holocave_cave::{Size, WallView};
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
                    size: Size::new(w, h),
                },
                0.05,
            )
            .expect("the eye is in front of the wall")
        })
        .collect()
}

/// The per-eye sizes a bench runs at: `defaults`, and the one in `HOLOCAVE_BENCH_WALL`
/// (`WxH`, e.g. `1920x1200`: a projector's wall, for `benches/gpu_rays.sh` on a GPU).
pub fn sizes(defaults: &[Size]) -> Vec<Size> {
    let mut out = defaults.to_vec();
    if let Ok(s) = std::env::var("HOLOCAVE_BENCH_WALL") {
        match s.parse() {
            Ok(size) => out.push(size),
            Err(e) => eprintln!("HOLOCAVE_BENCH_WALL: {e}; ignored"),
        }
    }
    out
}
