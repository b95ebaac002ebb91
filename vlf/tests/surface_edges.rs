//! A bright square in front of a dark wall, or of nothing, drawn with one lookup per
//! pixel: along its outline each pixel shows the share of it each side covers
//! (`holocave_vlf::surface_edges`), not one of them whole.

use crate::common;

use std::sync::Arc;

use glam::Vec3;
use holocave_scene::color::luminance;
use holocave_vlf::glow_edges::EDGE_RAYS;
use holocave_vlf::surface_edges;
use holocave_vlf::view::shade_one;
use holocave_vlf::{Settings, Visibility};

/// The square's irradiance against the wall's: each shows `ρ/π` of it.
const BRIGHT: f32 = 60.0;
const DARK: f32 = 2.0;

/// Against the same view drawn with 32 × 32 lookups per pixel, every pixel along the
/// square's edges (its corners aside) is within `1 / (2 · EDGE_RAYS)` of the contrast
/// (the edges run along the pixels' rows and columns, each of which holds one of the
/// rays: `glow_edges::subpixel`) plus the reference's own
/// `1 / 64`; a corner's pixel, whose other side is taken from one neighbour, within twice
/// that; with one lookup a pixel the edge cuts is off by a good part of the contrast.
#[test]
fn a_bright_squares_edges_show_the_share_of_each_pixel_it_covers() {
    // The square moved by fractions of a pixel, so its edges cut pixels whose centres
    // see it and pixels whose centres see the wall.
    let mut before_worst = 0.0f32;
    let mut looked = 0;
    for shift in [0.0f32, 0.011, 0.023, 0.034] {
        let (before, n) = bright_square_edges(Vec3::new(-0.37 + shift, -0.29 + shift, -1.5), true);
        before_worst = before_worst.max(before);
        looked += n;
    }
    assert!(looked > 100, "{looked} pixels looked at");
    assert!(
        before_worst > 0.4 * contrast(DARK),
        "the edges cut pixels: {before_worst}"
    );
}

/// The same with nothing behind the square: the pixels outside it whose centres see
/// nothing take the share of them the square covers.
#[test]
fn a_bright_square_before_nothing_shows_the_share_of_each_pixel_it_covers() {
    let mut before_worst = 0.0f32;
    for shift in [0.0f32, 0.011, 0.023, 0.034] {
        let (before, _) = bright_square_edges(Vec3::new(-0.37 + shift, -0.29 + shift, -1.5), false);
        before_worst = before_worst.max(before);
    }
    assert!(
        before_worst > 0.4 * contrast(0.0),
        "the edges cut pixels: {before_worst}"
    );
}

fn contrast(dark: f32) -> f32 {
    (BRIGHT - dark) * 0.5 * std::f32::consts::FRAC_1_PI
}

/// Asserts the bounds for the square with its corner at `o`, before the dark wall or
/// before nothing; returns the worst error along an edge with one lookup, and how many
/// pixels were looked at.
fn bright_square_edges(o: Vec3, wall: bool) -> (f32, usize) {
    let (a, b) = (0.78, 0.7);
    let materials = [
        common::lambert("wall", 0.5, Vec3::ZERO),
        common::lambert("square", 0.5, Vec3::ZERO),
    ];
    let scene = if wall {
        common::square_before_a_wall("a bright square", o, (a, b), materials)
    } else {
        let square = common::quad(o, Vec3::X * a, Vec3::Y * b);
        let tris: Vec<_> = square.iter().map(|t| (*t, 1)).collect();
        common::scene(
            "a bright square alone",
            &tris,
            materials.to_vec(),
            Vec::new(),
        )
    };
    let vis = Visibility::of(Arc::new(scene), &Settings::default());
    let dark = if wall { DARK } else { 0.0 };
    let mut values = vec![[dark; 3]; vis.tiles().elements as usize];
    let square = if wall { 2..4 } else { 0..2 };
    for t in square {
        let c = vis.elements().triangles[t];
        let cells = holocave_vlf::elements::cells(c.res);
        for e in c.base(0)..c.base(1) + cells {
            values[e as usize] = [BRIGHT; 3];
        }
    }
    let view = common::edge_view();
    let reference = vis.render(&view, &values, 32);
    let corners = common::corner_pixels(&view, o, (a, b));
    assert_eq!(corners.len(), 4);
    let worst = |lookups: &[holocave_vlf::Lookup]| {
        let mut w = (0.0f32, 0.0f32);
        for (i, (l, r)) in lookups.iter().zip(&reference.pixels).enumerate() {
            let e = (luminance(shade_one(l, &values)) - luminance(*r)).abs();
            if corners.contains(&i) {
                w.1 = w.1.max(e);
            } else {
                w.0 = w.0.max(e);
            }
        }
        w
    };
    let (mut lookups, points) = vis.pixels_and_points(&view);
    let before = worst(&lookups);
    vis.draw_with(Arc::new(values.clone()), false);
    let looked = surface_edges::resolve(&vis, &view, &mut lookups, &points, &[]);
    let after = worst(&lookups);
    let n = EDGE_RAYS as f32;
    let edge = contrast(dark) * (0.5 / n + 1.0 / 64.0);
    eprintln!(
        "corner at {o}: {looked} pixels looked at; worst error along an edge {:.3} with one \
         lookup, {:.3} resolved (bound {edge:.3}); at a corner {:.3}, {:.3}",
        before.0, after.0, before.1, after.1
    );
    assert!(after.0 <= edge, "along an edge {}, bound {edge}", after.0);
    assert!(
        after.1 <= 2.0 * edge,
        "at a corner {}, bound {}",
        after.1,
        2.0 * edge
    );
    (before.0, looked)
}
