//! The edges of what glows on the walls — an emitter, the sky through a window — drawn
//! with the share of the pixel each side covers.
//!
//! A wall takes one lookup through each pixel's centre, so a lamp's outline was a
//! staircase of whole pixels, lamp or ceiling, which the render cache's jittered samples
//! smooth only where the head stays still: on the Cornell box's front wall the lamp's
//! outline (the 1 % of pixels with the largest error) made 70 % of the light field's
//! relative error against a pixel-averaged reference. Where a pixel's glow differs from a
//! neighbour's by more than [`CONTRAST`], [`EDGE_RAYS`] rays through the pixel find what
//! glows along them and whether they end on a surface that does not: the lookup's
//! surface part (its element or tile, and the direct light per pixel) is scaled to the
//! share of the rays that end on a surface, and its glow is the rays' mean. A pixel whose
//! centre glows takes its surface part from a neighbour whose centre does not. Only glow
//! is resolved: an edge between two surfaces that do not glow stays one lookup's.

use glam::{Vec2, Vec3};
use holocave_cave::WallView;
use holocave_scene::PlacedScene;
use holocave_scene::color::luminance;
use rayon::prelude::*;

use crate::pixel_direct::DirectPoint;
use crate::view::{Lookup, Visibility};

/// Rays through each pixel at an edge, at the points of [`subpixel`] (a power of two).
pub const EDGE_RAYS: u32 = 16;

/// The `s`-th of the [`EDGE_RAYS`] points in a pixel at which the edges' rays cross it:
/// Hammersley's, `((s + ½)/n, φ₂(s) + ½/n)` (`φ₂` the base-2 radical inverse), each in
/// its own of `n` rows and of `n` columns, so that a pixel's share of an edge along its
/// rows or columns is found to within `1/(2n)`. A regular `k × k` grid has only `k`
/// rows: an edge along them (a table top's front edge on a floor wall) was found to
/// within `1/(2k)`, an eighth of the pixel at 16 rays.
pub fn subpixel(s: u32) -> Vec2 {
    let bits = EDGE_RAYS.trailing_zeros();
    let inverse = s.reverse_bits() >> (32 - bits);
    Vec2::new(s as f32 + 0.5, inverse as f32 + 0.5) / EDGE_RAYS as f32
}

/// Glow differing from a neighbour's by more than this share of the larger marks an edge.
pub const CONTRAST: f32 = 0.25;

/// The pixels of one view at a glowing edge, with what they need once the direct light is
/// added to the lookups: their glow as their lookups held it before, and the neighbour
/// whose lookup shades their surface part.
#[derive(Clone)]
pub struct GlowEdges {
    pixels: Vec<Edge>,
}

#[derive(Clone)]
struct Edge {
    pixel: usize,
    /// What this pixel's lookup held of glow before the direct light was added.
    glow: Vec3,
    /// A neighbour whose lookup shades a surface, and its glow before the direct light.
    beside: Option<(usize, Vec3)>,
}

/// What a lookup's `emitted` light holds of glow alone, where it holds nothing else
/// before the direct light is added: an element's or a tile's (the emitters and sky on the
/// way and at the end, less what it holds of surfaces: [`DirectPoint::surfaces`]), or
/// nothing seen at all. A surface drawn as its mirror holds its reflections there too,
/// and is left as it is.
fn glow_of(l: &Lookup, point: Option<&DirectPoint>) -> Option<Vec3> {
    let shaded = l.base != u32::MAX || l.tile != u32::MAX;
    let surfaces = point.map_or(Vec3::ZERO, |p| p.surfaces);
    (shaded || point.is_none()).then(|| Vec3::from(l.emitted) - surfaces)
}

/// The four neighbours of pixel `i` of a `w` × `h` image (rows from the top) that lie in
/// it.
pub(crate) fn neighbours(i: usize, w: usize, h: usize) -> impl Iterator<Item = usize> {
    let (x, y) = (i % w, i / w);
    [
        (x > 0).then(|| i - 1),
        (x + 1 < w).then(|| i + 1),
        (y > 0).then(|| i - w),
        (y + 1 < h).then(|| i + w),
    ]
    .into_iter()
    .flatten()
}

/// The pixels of `view` (rows from the top) whose glow differs from a neighbour's, found
/// in `lookups` and their `points` before the direct light is added.
pub fn find(view: &WallView, lookups: &[Lookup], points: &[Option<DirectPoint>]) -> GlowEdges {
    let (w, h) = (view.size.width as usize, view.size.height as usize);
    let glow = |i: usize| glow_of(&lookups[i], points.get(i).and_then(Option::as_ref));
    let neighbours = move |i: usize| neighbours(i, w, h);
    let pixels = (0..(w * h).min(lookups.len()))
        .into_par_iter()
        .filter_map(|i| {
            let g = glow(i)?;
            let a = luminance(g);
            let differs = neighbours(i).any(|j| {
                glow(j).is_some_and(|gj| {
                    let b = luminance(gj);
                    (a - b).abs() > CONTRAST * a.max(b)
                })
            });
            if !differs {
                return None;
            }
            // The neighbour that glows least and shades a surface.
            let beside = neighbours(i)
                .filter(|&j| lookups[j].base != u32::MAX || lookups[j].tile != u32::MAX)
                .filter_map(|j| glow(j).map(|gj| (j, gj)))
                .min_by(|a, b| luminance(a.1).total_cmp(&luminance(b.1)));
            Some(Edge {
                pixel: i,
                glow: g,
                beside,
            })
        })
        .collect();
    GlowEdges { pixels }
}

impl GlowEdges {
    /// How many pixels are at an edge.
    pub fn len(&self) -> usize {
        self.pixels.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pixels.is_empty()
    }

    /// The pixels at an edge, in order.
    pub fn pixels(&self) -> Vec<usize> {
        self.pixels.iter().map(|e| e.pixel).collect()
    }

    /// Draws the edges' pixels of `lookups` (the direct light per pixel added since they
    /// were found, or not) with the share of each pixel that glows, seen by `vis` in
    /// `view`.
    pub fn resolve(&self, vis: &Visibility, view: &WallView, lookups: &mut [Lookup]) {
        let resolved: Vec<(usize, Lookup)> = vis.with_placed(|placed| {
            (self.pixels.par_iter())
                .map(|e| {
                    let c = Coverage::of(vis, placed, view, e.pixel);
                    (e.pixel, c.drawn(e, lookups))
                })
                .collect()
        });
        for (i, l) in resolved {
            lookups[i] = l;
        }
    }
}

/// What the rays through one pixel find.
struct Coverage {
    /// The ray through its centre ends on a surface that does not glow.
    centre_on_surface: bool,
    /// The mean glow of the [`EDGE_RAYS`] rays.
    glow: Vec3,
    /// The share of them that end on a surface that does not glow.
    share: f32,
}

impl Coverage {
    fn of(vis: &Visibility, placed: &PlacedScene, view: &WallView, pixel: usize) -> Coverage {
        let corner = Vec2::new(
            (pixel as u32 % view.size.width) as f32,
            (pixel as u32 / view.size.width) as f32,
        );
        let along = |o: Vec2| vis.glow_along(placed, view.ray(corner + o));
        let (mut glow, mut on_surface) = (Vec3::ZERO, 0u32);
        for s in 0..EDGE_RAYS {
            let (g, surface) = along(subpixel(s));
            glow += g;
            on_surface += u32::from(surface);
        }
        Coverage {
            centre_on_surface: along(Vec2::splat(0.5)).1,
            glow: glow / EDGE_RAYS as f32,
            share: on_surface as f32 / EDGE_RAYS as f32,
        }
    }

    /// Edge pixel `e`'s lookup: its own surface part (or, where its centre glows, its
    /// neighbour's) scaled to the share, and the mean glow.
    fn drawn(&self, e: &Edge, lookups: &[Lookup]) -> Lookup {
        let surface_part = |l: &Lookup, own_glow: Vec3| Lookup {
            weight: (Vec3::from(l.weight) * self.share).to_array(),
            emitted: ((Vec3::from(l.emitted) - own_glow) * self.share + self.glow).to_array(),
            ..*l
        };
        let l = &lookups[e.pixel];
        match e.beside {
            _ if self.centre_on_surface => surface_part(l, e.glow),
            Some((j, beside_glow)) if self.share > 0.0 => surface_part(&lookups[j], beside_glow),
            _ => Lookup {
                emitted: (Vec3::from(l.emitted) - e.glow + self.glow).to_array(),
                ..*l
            },
        }
    }
}
