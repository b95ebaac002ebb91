//! A flat box resting on a floor under a uniform sky: the floor's elements (and pools of
//! them) along its foot lie partly under it, where no line reaches. Their lines' light is
//! put over their open part (`bake::over_open_part`, `Pools::new`), so the field holds
//! the same light along the foot as anywhere on the open floor, but for the little sky the
//! box hides.

use crate::common;

use std::sync::Arc;

use glam::Vec3;
use holocave_scene::{Daylight, Ray, Sky, SkyModel};
use holocave_vlf::{Settings, Visibility};

#[test]
fn the_floor_along_a_boxs_foot_holds_the_open_floors_light() {
    // A Lambertian floor, and a black box 1 m × H × 3 m standing on it (outward faces),
    // its foot at x = FOOT, off the elements' grid.
    const FOOT: f32 = 0.0123;
    const H: f32 = 0.0005;
    let mut tris: Vec<([Vec3; 3], u32)> = common::floor(3.0).map(|t| (t, 0)).to_vec();
    let (lo, size) = (Vec3::new(FOOT, 0.0, -1.5), Vec3::new(1.0, H, 3.0));
    for axis in 0..3 {
        let (mut a, mut b) = (Vec3::ZERO, Vec3::ZERO);
        a[(axis + 1) % 3] = size[(axis + 1) % 3];
        b[(axis + 2) % 3] = size[(axis + 2) % 3];
        let mut far = lo;
        far[axis] += size[axis];
        // a × b along +axis: the near face faces outwards with a and b swapped.
        for q in [common::quad(lo, b, a), common::quad(far, a, b)] {
            tris.extend(q.map(|t| (t, 1)));
        }
    }
    let daylight = Daylight {
        sky: Some(Sky {
            model: SkyModel::Uniform(Vec3::ONE),
            ground: Vec3::ZERO,
        }),
        ..Default::default()
    };
    let scene = Arc::new(common::scene_of(
        "box on a floor",
        &tris,
        vec![
            common::lambert("floor", 0.5, Vec3::ZERO),
            common::lambert("box", 0.0, Vec3::ZERO),
        ],
        |p| p.daylight = daylight,
    ));
    let settings = Settings {
        directions: 642,
        resolution: 128,
        element_size: Some(0.05),
        ..Settings::default()
    };
    let (state, _) = common::bake_quiet(&scene, &settings);
    let vis = Visibility::of(scene.clone(), &settings);
    // The drawn irradiance of the floor's element under (x, z), found from below (the
    // same triangle and barycentrics as from above, where the box may be in the way).
    let at = |x: f32, z: f32| -> f32 {
        let ray = Ray::new(Vec3::new(x, -1.0, z), Vec3::Y);
        let h = scene.closest_hit(&ray, f32::INFINITY).expect("the floor");
        let e = vis.elements().element(h.triangle, 0, h.u, h.v);
        state.irradiance[e as usize][0]
    };
    // A centimetre from the foot, every 5 mm over its middle 2.4 m (the element at each
    // point often one the box's foot crosses), and along a line a metre away.
    const FROM_FOOT: f32 = 0.01;
    let zs: Vec<f32> = (0..480).map(|k| -1.2 + 0.005 * k as f32).collect();
    let foot: Vec<f32> = zs.iter().map(|&z| at(FOOT - FROM_FOOT, z)).collect();
    let open: Vec<f32> = zs.iter().map(|&z| at(FOOT - 1.0, z)).collect();
    let mean = |v: &[f32]| v.iter().sum::<f32>() / v.len() as f32;
    let (m_foot, m_open) = (mean(&foot), mean(&open));
    // The open floor's spread between elements (the lines' sampling, after the
    // smoothing), and how many independent elements a line of 2.4 m holds: one every
    // three elements' widths (the smoothing spans three).
    let sd = (open.iter().map(|v| (v - m_open).powi(2)).sum::<f32>() / open.len() as f32).sqrt();
    let independent: f32 = 2.4 / (3.0 * 0.05);
    // The sky the box hides: a wall of height H hides `½ (1 − d/√(d² + H²))` of the
    // cosine-weighted sky at distance d; over an element's open part from the foot out to
    // L, `½ (1 − (√(L² + H²) − H)/L)`, the most for the shortest such part that holds a
    // point, L = FROM_FOOT.
    let l = FROM_FOOT;
    let hidden = 0.5 * (1.0 - ((l * l + H * H).sqrt() - H) / l);
    let bound = 4.0 * sd * (2.0 / independent).sqrt() + hidden * m_open;
    eprintln!(
        "along the foot {m_foot:.4}, a metre away {m_open:.4} (spread {sd:.4}); bound {bound:.4}; π = {:.4}",
        std::f32::consts::PI
    );
    assert!(
        (m_foot - m_open).abs() <= bound,
        "the floor along the box's foot holds {m_foot:.4}, the open floor {m_open:.4} ± {bound:.4}"
    );
}
