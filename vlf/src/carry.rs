//! A moving eye's pixels carried to its next view, as the render cache carries its points
//! (`papers/render-cache.md` §3–4): work in proportion to what changed.
//!
//! Each pixel of the last frame whose point the eye saw straight (not through a mirror or
//! glass, not on a moving object: [`DirectPoint::span`] is not zero) is projected into the
//! new view; the pixel it lands in takes it, the nearest point winning where several land
//! in one. A pixel keeps what it carried (its surface, its lookup and its light) instead
//! of being drawn anew, unless:
//!
//! - nothing landed in it (a point newly in sight, the view's edge, the sky, a mirror's
//!   image, a moving object);
//! - it lies on an outline, where a point carried from beside it may be one the eye no
//!   longer sees: a neighbour got a point more than [`DEPTH_STEP`] nearer or farther, or
//!   the pixel it carries from lay on one in the last frame (beside a pixel whose point
//!   could not be carried, against the sky or a mirror, or beside a step in depth). A
//!   neighbour that got nothing because two points landed in one pixel does not count:
//!   it is drawn anew itself;
//! - it has been carried for its age limit: [`DIFFUSE_AGE`] frames where what it shows
//!   does not depend on the eye's direction, [`GLOSSY_AGE`] where it does (a glossy tile's
//!   direction, a sharpened reflection, a lobe's reflection drawn per frame: the
//!   view-dependent part is refreshed twice as often, never re-weighted).
//!
//! A carried point lies within half a pixel of the ray through its new pixel's centre, on
//! the surface that pixel sees: what it shows is that surface's light a fraction of a pixel
//! away, the render cache's own approximation, however long it is carried: what ageing
//! brings back is the convergence of its light (a carried pixel's mean takes no
//! estimates) and the surface's view-dependent part. Ages start staggered ([`stagger`]),
//! so each frame in motion draws an eighth of a diffuse view anew, not all of it every
//! eighth frame.

use glam::Vec3;
use holocave_cave::WallView;
use rayon::prelude::*;

use crate::glow_edges::neighbours;
use crate::pixel_direct::DirectPoint;

/// Frames a pixel whose light does not depend on the eye's direction is carried before it
/// is drawn anew.
pub const DIFFUSE_AGE: u8 = 8;

/// Frames a pixel whose light depends on the eye's direction is carried before it is
/// drawn anew.
pub const GLOSSY_AGE: u8 = 2;

/// A neighbour's point nearer or farther than this share of a pixel's depth marks an
/// outline: a plane seen at 80° from its normal steps `tan 80° × 0.7°` = 7 % in depth
/// from pixel to pixel of a 128-pixel-wide view of 90°, an object's silhouette against
/// the wall behind it tens of per cent.
pub const DEPTH_STEP: f32 = 0.1;

/// Where each pixel of a new view takes what it shows from.
#[derive(Clone, Debug, PartialEq)]
pub struct Carried {
    /// The last frame's pixel it carries, or `None`: drawn anew.
    pub from: Vec<Option<u32>>,
    /// Frames since each pixel was drawn anew (0 for those drawn now).
    pub ages: Vec<u8>,
}

impl Carried {
    /// How many pixels are drawn anew.
    pub fn drawn(&self) -> usize {
        self.from.iter().filter(|f| f.is_none()).count()
    }
}

/// The age a pixel drawn on a whole frame starts at: 0–7 in a 4 × 2 pattern, so that an
/// eighth of a diffuse region comes to its age limit each frame.
pub fn stagger(view: &WallView, i: usize) -> u8 {
    let w = view.size.width as usize;
    let (x, y) = (i % w, i / w);
    [[0, 4, 2, 6], [5, 1, 7, 3]][y % 2][x % 4]
}

/// The frames a pixel's light may be carried: [`GLOSSY_AGE`] where it depends on the
/// eye's direction, else [`DIFFUSE_AGE`].
pub fn age_limit(view_dependent: bool) -> u8 {
    if view_dependent {
        GLOSSY_AGE
    } else {
        DIFFUSE_AGE
    }
}

/// Which of the last frame's pixels (seen from `from`, at `points`, carried for `ages`
/// frames, each at most `limit(i)` frames: [`age_limit`], or 0 where something else
/// changed what it shows) each pixel of `to` (the same screen, the eye moved) carries.
pub fn carry(
    from: &WallView,
    to: &WallView,
    (points, ages): (&[Option<DirectPoint>], &[u8]),
    limit: impl Fn(usize) -> u8 + Sync,
) -> Carried {
    let (w, h) = (to.size.width as usize, to.size.height as usize);
    let n = w * h;
    if !from.same_screen(to) || points.len() != n || ages.len() != n {
        return Carried {
            from: vec![None; n],
            ages: vec![0; n],
        };
    }
    let landed = land(to, points);
    let edged = outlined(from, points);
    let depth = |j: usize| landed[j].map(|(_, d)| d);
    let from: Vec<Option<u32>> = (0..n)
        .into_par_iter()
        .map(|j| {
            let (i, d) = landed[j]?;
            let outline = edged[i as usize]
                || neighbours(j, w, h)
                    .any(|k| depth(k).is_some_and(|dk| (dk - d).abs() > DEPTH_STEP * d));
            (ages[i as usize] + 1 < limit(i as usize) && !outline).then_some(i)
        })
        .collect();
    let ages = (from.iter())
        .map(|f| f.map_or(0, |i| ages[i as usize] + 1))
        .collect();
    Carried { from, ages }
}

/// A point a pixel may carry: one seen straight, not through a mirror or glass, and not on
/// a moving object (its estimates are spread over the pixel: [`DirectPoint::span`]).
fn carriable(p: &Option<DirectPoint>) -> Option<&DirectPoint> {
    p.as_ref().filter(|p| p.span != [Vec3::ZERO; 2])
}

/// For each pixel of `to`, the last frame's pixel whose point lands in it nearest the
/// eye, and that point's distance from the eye. Points carried for different numbers of
/// frames sit at different places in their pixels, and two of them meet in one pixel as
/// often as a pixel beside them is left empty: that pixel is drawn anew. (Filling it with
/// the point that lost, a pixel away, drew a quarter fewer pixels anew on a walking
/// head's front wall but raised the Cornell box's error in motion from 2.01·10⁻³ to
/// 2.08·10⁻³, against 1.81·10⁻³ without carrying.)
fn land(to: &WallView, points: &[Option<DirectPoint>]) -> Vec<Option<(u32, f32)>> {
    let (w, h) = (to.size.width as usize, to.size.height as usize);
    let targets: Vec<Option<(f64, f64, f32)>> = points
        .par_iter()
        .map(|p| {
            let p = carriable(p)?;
            let v = p.position - to.eye;
            let (x, y) = to.project(v.as_dvec3())?;
            let inside = x >= 0.0 && y >= 0.0 && x < w as f64 && y < h as f64;
            inside.then_some((x, y, v.length()))
        })
        .collect();
    let pixel = |x: f64, y: f64| y as usize * w + x as usize;
    let mut landed: Vec<Option<(u32, f32)>> = vec![None; w * h];
    for (i, t) in targets.iter().enumerate() {
        if let &Some((x, y, d)) = t
            && landed[pixel(x, y)].is_none_or(|(_, dj)| d < dj)
        {
            landed[pixel(x, y)] = Some((i as u32, d));
        }
    }
    landed
}

/// The pixels of the last frame (seen from `from`) on an outline: beside a pixel that saw
/// no point it could carry, or one more than [`DEPTH_STEP`] nearer or farther.
fn outlined(from: &WallView, points: &[Option<DirectPoint>]) -> Vec<bool> {
    let (w, h) = (from.size.width as usize, from.size.height as usize);
    let depth = |i: usize| Some((carriable(&points[i])?.position - from.eye).length());
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let Some(d) = depth(i) else { return true };
            neighbours(i, w, h).any(|k| depth(k).is_none_or(|dk| (dk - d).abs() > DEPTH_STEP * d))
        })
        .collect()
}

#[cfg(test)]
mod tests;
