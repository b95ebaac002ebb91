//! A glowing square's outline on a wall drawn with one lookup per pixel: at its edges
//! each pixel shows the share of it that glows (`holocave_vlf::glow_edges`), not the
//! lamp or the wall whole.

use crate::common;

use std::sync::Arc;

use glam::Vec3;
use holocave_scene::color::luminance;
use holocave_vlf::glow_edges::{self, EDGE_RAYS};
use holocave_vlf::view::shade_one;
use holocave_vlf::{Settings, Visibility};

const GLOW: f32 = 10.0;
const IRRADIANCE: f32 = 20.0;

/// Against the same view drawn with 32 × 32 lookups per pixel, every pixel of the
/// one-lookup drawing with its edges resolved is within `1 / (2 · EDGE_RAYS)` of the
/// glow along an edge (the square's edges run along the pixels' rows and columns, each
/// of which holds one of the rays: `glow_edges::subpixel`), twice that at a corner, plus
/// the reference's own `1 / 64`; without, a pixel the edge
/// cuts near its middle is off by about half the contrast. The square's edges cut the
/// pixels at fractions of them; the wall behind shows `ρ/π` of an irradiance of 20, a
/// third of the glow, so a pixel that kept its whole surface part would be off by it.
#[test]
fn a_glowing_squares_edges_show_the_share_of_each_pixel_that_glows() {
    let (o, size) = (Vec3::new(-0.37, -0.29, -1.5), (0.78, 0.7));
    let materials = [
        common::lambert("wall", 0.5, Vec3::ZERO),
        common::lambert("lamp", 0.0, Vec3::splat(GLOW)),
    ];
    let scene = common::square_before_a_wall("a glowing square", o, size, materials);
    let scene = Arc::new(scene);
    let vis = Visibility::of(scene, &Settings::default());
    let values = vec![[IRRADIANCE; 3]; vis.tiles().elements as usize];
    let contrast = GLOW - 0.5 * std::f32::consts::FRAC_1_PI * IRRADIANCE;
    let view = common::edge_view();
    let reference = vis.render(&view, &values, 32);
    let (mut lookups, points) = vis.pixels_and_points(&view);
    let shown = |lookups: &[holocave_vlf::Lookup]| -> Vec<f32> {
        lookups
            .iter()
            .map(|l| luminance(shade_one(l, &values)))
            .collect()
    };
    // The pixels holding a corner of the square, where two edges meet.
    let corners = common::corner_pixels(&view, o, size);
    assert_eq!(corners.len(), 4);
    // The worst error on a pixel an edge crosses, and on one holding a corner.
    let worst = |shown: &[f32]| {
        let mut w = (0.0f32, 0.0f32);
        for (i, (s, r)) in shown.iter().zip(&reference.pixels).enumerate() {
            let e = (s - luminance(*r)).abs();
            if corners.contains(&i) {
                w.1 = w.1.max(e);
            } else {
                w.0 = w.0.max(e);
            }
        }
        w
    };
    let before = worst(&shown(&lookups));
    let edges = glow_edges::find(&view, &lookups, &points);
    edges.resolve(&vis, &view, &mut lookups);
    let after = worst(&shown(&lookups));
    // One edge along the pixels' rows or columns: half of one of the rays' rows or
    // columns; a corner: the two edges'. The reference's own: 1/64.
    let n = EDGE_RAYS as f32;
    let (edge, corner) = (
        contrast * (0.5 / n + 1.0 / 64.0),
        contrast * (1.0 / n + 2.0 / 64.0),
    );
    eprintln!(
        "{} pixels at the edges; worst error along an edge {:.3} with one lookup, {:.3} \
         resolved (bound {edge:.3}); at a corner {:.3}, {:.3} (bound {corner:.3})",
        edges.len(),
        before.0,
        after.0,
        before.1,
        after.1
    );
    assert!(
        before.0 > 0.3 * contrast,
        "the edges cut pixels: {}",
        before.0
    );
    assert!(after.0 <= edge, "along an edge {}, bound {edge}", after.0);
    assert!(after.1 <= corner, "at a corner {}, bound {corner}", after.1);
}
