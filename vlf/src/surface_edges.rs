//! The edges between two surfaces seen side by side — a sunlit floor beside a dark wall —
//! drawn with the share of each pixel that each covers.
//!
//! A wall takes one lookup through each pixel's centre, so where a bright surface meets a
//! dark one, each pixel along the edge showed one of them whole: on the room's floor wall,
//! seen by a still head, one such column (ours 4, the pixel-averaged reference 31) made
//! most of the light field's relative error. Where a pixel's radiance differs from a
//! neighbour's by more than [`CONTRAST`], [`EDGE_RAYS`] rays through the pixel find the
//! share that sees the plane of its centre's point; the rest of the pixel is taken to
//! look like the neighbour beyond the edge (the one it differs from most whose point is
//! not on that plane), whose radiance, shaded as the walls shade it, joins the lookup's
//! emitted light while the lookup's own part is scaled to its share.
//!
//! A pixel whose centre sees no surface point (its ray leaves the scene, or a mirror
//! shows nothing) is the dark side of such an edge: there the rays find the share that
//! sees the plane of the neighbour's point, which takes that neighbour's radiance. On the
//! Cornell box's front wall the floor's front edge and the mirror's outline were a
//! quarter of the light field's error while only the bright side was drawn so.

use glam::{Vec2, Vec3};
use holocave_cave::WallView;
use holocave_scene::color::luminance;
use rayon::prelude::*;

use crate::glow_edges::{EDGE_RAYS, neighbours, subpixel};
use crate::pixel_direct::DirectPoint;
use crate::view::{Lookup, Visibility, shade_one};

/// Radiance differing from a neighbour's by more than this share of the larger, and by
/// more than [`FLOOR`] of the view's mean, marks an edge worth the rays.
pub const CONTRAST: f32 = 0.5;
pub const FLOOR: f32 = 0.1;

/// Whether `at` lies on the plane of `p` (within the rounding of a hit `t` away).
fn on_plane(p: &DirectPoint, at: Vec3, t: f32) -> bool {
    p.normal.dot(at - p.position).abs() <= 1e-3 * t.max(1.0)
}

/// Draws the pixels of `lookups` (those of `view`, rows from the top, their points in
/// `points`) at edges between surfaces with each side's share, but for those in
/// `glowing` (in order: [`crate::glow_edges`]'), shading the far side from the values
/// `vis` draws with ([`Visibility::draw_with`]: nothing without them); returns how many
/// pixels it looked at.
pub fn resolve(
    vis: &Visibility,
    view: &WallView,
    lookups: &mut [Lookup],
    points: &[Option<DirectPoint>],
    glowing: &[usize],
) -> usize {
    vis.with_drawn(|values, _| match values {
        Some(values) => resolve_with(vis, view, lookups, (points, values), glowing),
        None => 0,
    })
}

fn resolve_with(
    vis: &Visibility,
    view: &WallView,
    lookups: &mut [Lookup],
    (points, values): (&[Option<DirectPoint>], &[[f32; 3]]),
    glowing: &[usize],
) -> usize {
    let (w, h) = (view.size.width as usize, view.size.height as usize);
    let n = (w * h).min(lookups.len()).min(points.len());
    let shown: Vec<f32> = (lookups[..n].par_iter())
        .map(|l| luminance(shade_one(l, values)))
        .collect();
    let floor = FLOOR * shown.par_iter().sum::<f32>() / n.max(1) as f32;
    let neighbours = move |i: usize| neighbours(i, w, h);
    let differs = |i: usize, j: usize| {
        let d = (shown[i] - shown[j]).abs();
        d > CONTRAST * shown[i].max(shown[j]) && d > floor
    };
    let pixels: Vec<usize> = (0..n)
        .into_par_iter()
        .filter(|&i| {
            neighbours(i).any(|j| differs(i, j) && (points[i].is_some() || points[j].is_some()))
        })
        .filter(|i| glowing.binary_search(i).is_err())
        .collect();
    let drawn: Vec<(usize, Lookup)> = vis.with_placed(|placed| {
        (pixels.par_iter())
            .filter_map(|&i| {
                let d = |j: usize| (shown[i] - shown[j]).abs();
                let widest =
                    |js: &mut dyn Iterator<Item = usize>| js.max_by(|&a, &b| d(a).total_cmp(&d(b)));
                // The neighbour beyond the edge, and the plane whose share of the pixel
                // is this pixel's own: with a point of its own, the neighbour it differs
                // from most whose point is elsewhere than this point's plane, and this
                // point's plane; without, the neighbour it differs from most that has a
                // point, and everything but that point's plane.
                let (beyond, plane, own_is_on) = match points[i].as_ref() {
                    Some(p) => {
                        let beyond = widest(&mut neighbours(i).filter(|&j| {
                            differs(i, j)
                                && points[j]
                                    .as_ref()
                                    .is_none_or(|q| !on_plane(p, q.position, 1.0))
                        }))?;
                        (beyond, p, true)
                    }
                    None => {
                        let beyond = widest(
                            &mut neighbours(i).filter(|&j| differs(i, j) && points[j].is_some()),
                        )?;
                        (beyond, points[beyond].as_ref()?, false)
                    }
                };
                let corner = Vec2::new((i % w) as f32, (i / w) as f32);
                let on = (0..EDGE_RAYS)
                    .filter(|s| {
                        let ray = view.ray(corner + subpixel(*s));
                        placed
                            .closest_hit(&ray, f32::INFINITY)
                            .is_some_and(|hit| on_plane(plane, ray.at(hit.t), hit.t))
                    })
                    .count();
                let all = EDGE_RAYS as usize;
                let own = if own_is_on { on } else { all - on };
                let share = own as f32 / all as f32;
                if own == 0 || own == all {
                    return None;
                }
                let l = &lookups[i];
                let other = shade_one(&lookups[beyond], values);
                Some((
                    i,
                    Lookup {
                        weight: (Vec3::from(l.weight) * share).to_array(),
                        emitted: (Vec3::from(l.emitted) * share + other * (1.0 - share)).to_array(),
                        ..*l
                    },
                ))
            })
            .collect()
    });
    for (i, l) in drawn {
        lookups[i] = l;
    }
    pixels.len()
}
