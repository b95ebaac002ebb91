//! A glossy surface whose lobe is narrower than its tile resolves shows the room its own
//! lobe reflects (`Visibility::sharpened_reflection`): a small lit square reflected in a
//! varnished floor, as the walls draw it, against the path tracer.

use crate::common;

use std::sync::Arc;

use glam::Vec3;
use holocave_cave::{Size, WallView};
use holocave_scene::{Material, Scene};
use holocave_vlf::tiles::alpha_floor;
use holocave_vlf::view::{ReflectionFrames, SHARPENED_RAYS};
use holocave_vlf::{Settings, Visibility, WallPass};

/// A varnished floor (black under its varnish; GGX α 0.0625, a quarter of what its tiles
/// resolve here) before a small white square standing on it, lit by a point light beside
/// the view; the eye looks down at the square's reflection. Each 8 × 8 bin of the floor's
/// tiles spans about 18°, as wide as the square seen from the floor, so the tile spreads
/// the reflection over its bin and beyond the region; the pixels take it from the floor's
/// own lobe. Where the path tracer shows the reflection (its pixels more than twice the
/// floor's darker quarter), the view's mean is the path tracer's within an eighth: what
/// is left of the tile there is the widened lobe's share of the reflection, about a
/// quarter of it (the square, 0.05 sr from the floor, against the widened lobe's
/// `π α²` of 0.21 sr), of which its bins move up to half out of the region. The tile
/// alone draws the region half as bright (0.030 against 0.061; with the sharpening
/// 0.058).
#[test]
fn a_small_square_reflected_in_varnish_is_as_bright_as_the_path_tracers() {
    let (scene, pass, view) = square_before_varnish();
    let drawn = pass.render(&view, pass.values(), 2, 16);
    let (reference, _, _) = common::two_seed_reference(&scene, &view, 512);
    let luminance = |c: &Vec3| f64::from(c.element_sum()) / 3.0;
    let mut floor_level: Vec<f64> = reference.pixels.iter().map(luminance).collect();
    floor_level.sort_by(f64::total_cmp);
    let around = floor_level[floor_level.len() / 4];
    let region: Vec<usize> = (0..reference.pixels.len())
        .filter(|&i| luminance(&reference.pixels[i]) > 2.0 * around)
        .collect();
    assert!(
        region.len() >= 20,
        "the reflection covers {} pixels",
        region.len()
    );
    let mean = |image: &holocave_tracer::film::Image| {
        region
            .iter()
            .map(|&i| luminance(&image.pixels[i]))
            .sum::<f64>()
            / region.len() as f64
    };
    let (ours, theirs) = (mean(&drawn), mean(&reference));
    eprintln!(
        "reflection over {} pixels: drawn {ours}, path tracer {theirs} (floor around {around})",
        region.len()
    );
    assert!(
        (ours / theirs - 1.0).abs() < 0.125,
        "the reflection drawn {ours}, the path tracer's {theirs}"
    );
}

/// The scene of these tests: a varnished floor, a small white square standing on it, a
/// point light beside; laid out, baked, split and drawn as the walls draw it; and a view
/// looking down at the square's reflection.
fn square_before_varnish() -> (Arc<Scene>, WallPass, WallView) {
    let floor = common::floor(4.0);
    let square = common::quad(Vec3::new(-0.15, 0.05, -1.0), Vec3::X * 0.3, Vec3::Y * 0.3);
    let triangles: Vec<([Vec3; 3], u32)> = (floor.iter().map(|t| (*t, 0)))
        .chain(square.iter().map(|t| (*t, 1)))
        .collect();
    let varnish = Material {
        roughness: 0.25,
        specular: 1.0,
        ..common::lambert("varnish", 0.02, Vec3::ZERO)
    };
    let scene = Arc::new(common::scene(
        "a lit square before varnish",
        &triangles,
        vec![varnish, common::lambert("white", 0.9, Vec3::ZERO)],
        vec![common::point_light(Vec3::new(0.6, 0.25, -0.7), 2.0)],
    ));
    let settings = Settings {
        directions: 92,
        resolution: 48,
        ..Settings::default()
    };
    let (state, _) = common::bake_quiet(&scene, &settings);
    let vis = Visibility::of(scene.clone(), &settings);
    assert!(
        vis.tiles().tiles.iter().any(|g| g.widened),
        "the floor's tiles widen its lobe (to {})",
        alpha_floor(
            settings.tile_bins,
            Settings::rounded_directions(settings.directions)
        )
    );
    let pass = WallPass::new(vis, &settings, &state, false).unwrap();
    // The square's mirror image is at y < 0 behind z = −1: the eye sees it on the floor
    // around z = −0.45.
    let view = WallView {
        eye: Vec3::new(0.0, 0.5, 1.0),
        pa: Vec3::new(-0.3, 0.0, -0.2),
        pb: Vec3::new(0.3, 0.0, -0.2),
        pc: Vec3::new(-0.3, 0.0, -0.8),
        size: Size::new(32, 32),
    };
    (scene, pass, view)
}

/// A still view's frames take each lobe's directions on from the last frame's
/// (`ReflectionFrames`), so that a pixel's mean over its frames is the
/// reflection from all their directions: the mean of 32 frames' is the reflection from
/// all 32 frames' directions at once (to the float rounding of the sums, where no
/// frame's is held at what the tile shows), and against one from 1,024 frames'
/// directions its error is under a third of one frame's (an estimate's noise falls as
/// one over the root of its directions: 32 frames, √32 ≈ 5.7 times).
#[test]
fn a_still_views_reflections_take_more_directions_frame_after_frame() {
    let (_, pass, view) = square_before_varnish();
    let reflected = |first: u64, count: u64| -> Vec<f64> {
        let frames = ReflectionFrames {
            blurred: first..first + count,
            sharpened: first..first + count,
        };
        let mut points = Vec::new();
        (pass.visibility()).pixels_into(&view, None, &mut points, &frames);
        (points.iter())
            .map(|p| {
                p.as_ref()
                    .and_then(|p| p.reflected)
                    .map_or(0.0, |r| f64::from(r.element_sum()))
            })
            .collect()
    };
    let frames: Vec<Vec<f64>> = (0..32).map(|f| reflected(f, 1)).collect();
    let mean: Vec<f64> = (0..frames[0].len())
        .map(|i| frames.iter().map(|f| f[i]).sum::<f64>() / frames.len() as f64)
        .collect();
    let at_once = reflected(0, 32);
    // Where no frame's difference of the two lobes fell below what the tile shows (it is
    // held there, which the mean of the frames' does not undo).
    let mut compared = 0;
    for (i, (m, a)) in mean.iter().zip(&at_once).enumerate() {
        if *a > 0.0 && frames.iter().all(|f| f[i] > 0.0) {
            assert!((m - a).abs() <= 1e-4 * a, "pixel {i}: {m} against {a}");
            compared += 1;
        }
    }
    assert!(compared > 100, "{compared} pixels compared");
    let reference = reflected(0, 1024);
    let error = |x: &[f64]| -> f64 {
        (x.iter().zip(&reference))
            .map(|(x, r)| (x - r).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let (one, all) = (error(&frames[0]), error(&mean));
    eprintln!(
        "error against {} directions a lobe: one frame {one}, 32 frames {all}",
        1024 * SHARPENED_RAYS
    );
    assert!(one > 0.0, "the reflections are drawn from a few directions");
    assert!(all < one / 3.0, "one frame {one}, 32 frames {all}");
}
