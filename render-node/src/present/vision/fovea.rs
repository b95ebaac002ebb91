//! The foveal image (Ward Larson, Rushmeier & Piatko 1997): the picture reduced
//! to samples about one degree across — the size of the fovea — each the mean of the
//! pixels under it, with the direction it lies in seen from the eye and the solid angle it
//! covers. Veiling glare, the adaptation luminance that sets acuity, and the sources a wall
//! shares with the others are all computed on it.
//!
//! The grid knows nothing of the projection: it is built from a function that gives the
//! direction from the eye through any point of the image (for a planar wall,
//! `WallView::ray`), so the same code serves walls, cameras and test views.

use glam::{Vec2, Vec3};
use holocave_tracer::film::Image;

/// The fovea's diameter, degrees (`pcond`'s `FOVDIA`).
pub const FOVEA_DEG: f32 = 1.0;
/// At most this many foveal samples along a side (a 180° view at one degree).
pub const MAX_CELLS: u32 = 180;
/// A foveal sample is at least this many pixels across: a smaller picture (a simulated
/// CAVE's 128-pixel walls) gets samples of more than a degree. Its pixels cannot show
/// detail at one degree anyway, and the veil's cost, samples², falls from 44 M terms per
/// eye to under a million.
pub const MIN_CELL_PIXELS: u32 = 4;

/// The direction from the eye through a point of the image (pixels from the top-left
/// corner, fractional: `(0.5, 0.5)` is the first pixel's centre). Need not be normalised.
pub type PixelDirections<'a> = &'a dyn Fn(Vec2) -> Vec3;

/// The foveal grid of one image and view: `cols × rows` cells, cell `(i, j)` covering
/// pixels `i·W/cols .. (i+1)·W/cols` (integer division) and likewise in y.
#[derive(Clone, Debug, PartialEq)]
pub struct Fovea {
    pub width: u32,
    pub height: u32,
    pub cols: u32,
    pub rows: u32,
    /// Per cell, row by row: the unit direction of its centre.
    pub dirs: Vec<Vec3>,
    /// Per cell: the solid angle it covers, steradians.
    pub omega: Vec<f32>,
    /// Per cell: pixels per degree at its centre (the square root of a pixel's solid angle).
    pub pixels_per_degree: Vec<f32>,
}

impl Fovea {
    /// The grid of a `width × height` image seen through `dirs`: as many cells along each
    /// side as the view's angle across that side's middle in degrees (one cell per
    /// [`FOVEA_DEG`]), at least one, at most [`MAX_CELLS`] and one per
    /// [`MIN_CELL_PIXELS`] pixels.
    pub fn new(width: u32, height: u32, dirs: PixelDirections) -> Fovea {
        let (w, h) = (width as f32, height as f32);
        let d = |x: f32, y: f32| dirs(Vec2::new(x, y)).normalize_or_zero();
        let across = |a: Vec3, b: Vec3| a.angle_between(b).to_degrees();
        let count = |deg: f32, px: u32| {
            let most = MAX_CELLS.min(px / MIN_CELL_PIXELS).max(1);
            ((deg / FOVEA_DEG).round() as u32).clamp(1, most)
        };
        let cols = count(across(d(0.0, h * 0.5), d(w, h * 0.5)), width);
        let rows = count(across(d(w * 0.5, 0.0), d(w * 0.5, h)), height);
        let n = (cols * rows) as usize;
        let mut fovea = Fovea {
            width,
            height,
            cols,
            rows,
            dirs: Vec::with_capacity(n),
            omega: Vec::with_capacity(n),
            pixels_per_degree: Vec::with_capacity(n),
        };
        for j in 0..rows {
            for i in 0..cols {
                let ((x0, x1), (y0, y1)) = fovea.span(i, j);
                let (x0, x1, y0, y1) = (x0 as f32, x1 as f32, y0 as f32, y1 as f32);
                let (xc, yc) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
                // The cell's solid angle: the parallelogram its sides' directions span on
                // the unit sphere (exact to second order in its size, a degree or so).
                let omega = (d(x1, yc) - d(x0, yc))
                    .cross(d(xc, y1) - d(xc, y0))
                    .length();
                let pixel = omega / ((x1 - x0) * (y1 - y0));
                fovea.dirs.push(d(xc, yc));
                fovea.omega.push(omega);
                fovea
                    .pixels_per_degree
                    .push(1f32.to_radians() / pixel.max(1e-20).sqrt());
            }
        }
        fovea
    }

    /// The pixels of cell `(i, j)`: `((x0, x1), (y0, y1))`, ends excluded.
    pub fn span(&self, i: u32, j: u32) -> ((u32, u32), (u32, u32)) {
        let (w, h) = (u64::from(self.width), u64::from(self.height));
        let (c, r) = (u64::from(self.cols), u64::from(self.rows));
        let x = |i: u32| (u64::from(i) * w / c) as u32;
        let y = |j: u32| (u64::from(j) * h / r) as u32;
        ((x(i), x(i + 1)), (y(j), y(j + 1)))
    }

    /// Cells in all.
    pub fn len(&self) -> usize {
        self.dirs.len()
    }

    pub fn is_empty(&self) -> bool {
        self.dirs.is_empty()
    }

    /// The mean radiance of each cell of `image` (which must be `width × height`).
    pub fn means(&self, image: &Image) -> Vec<Vec3> {
        let mut out = Vec::with_capacity(self.len());
        for j in 0..self.rows {
            for i in 0..self.cols {
                let ((x0, x1), (y0, y1)) = self.span(i, j);
                let mut s = Vec3::ZERO;
                for y in y0..y1 {
                    for x in x0..x1 {
                        s += image.at(x, y);
                    }
                }
                out.push(s / ((x1 - x0) * (y1 - y0)).max(1) as f32);
            }
        }
        out
    }

    /// Bilinear interpolation of per-cell `values` at pixel `(x, y)`'s centre, the cells'
    /// values taken at their centres (Radiance `pcond`'s mapping of the foveal image onto
    /// the picture): the cells and weights `[(index, weight); 4]`.
    pub fn bilinear(&self, x: u32, y: u32) -> [(usize, f32); 4] {
        let axis = |p: u32, size: u32, cells: u32| {
            let g = (p as f32 + 0.5) * cells as f32 / size as f32 - 0.5;
            let g0 = g.floor();
            let t = g - g0;
            let last = cells as i64 - 1;
            let a = (g0 as i64).clamp(0, last) as usize;
            let b = (g0 as i64 + 1).clamp(0, last) as usize;
            (a, b, t)
        };
        let (x0, x1, tx) = axis(x, self.width, self.cols);
        let (y0, y1, ty) = axis(y, self.height, self.rows);
        let c = self.cols as usize;
        [
            (y0 * c + x0, (1.0 - tx) * (1.0 - ty)),
            (y0 * c + x1, tx * (1.0 - ty)),
            (y1 * c + x0, (1.0 - tx) * ty),
            (y1 * c + x1, tx * ty),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ninety_degree_wall_has_ninety_one_degree_cells_that_cover_it() {
        // A 2 m wide screen 1 m in front of the eye spans 90°: 90 cells across; their solid
        // angles sum to the screen's (4·asin(sin a·sin b) for a rectangle of half-angles a, b).
        let (w, h) = (720u32, 360u32);
        let dirs =
            move |p: Vec2| Vec3::new(-1.0 + 2.0 * p.x / w as f32, 0.5 - p.y / h as f32, -1.0);
        let f = Fovea::new(w, h, &dirs);
        assert_eq!((f.cols, f.rows), (90, 53));
        let total: f32 = f.omega.iter().sum();
        let (a, b) = (1f32.atan(), 0.5f32.atan());
        let want = 4.0 * (a.sin() * b.sin()).asin();
        assert!(
            (total - want).abs() < 2e-3 * want,
            "cells cover {total} sr, the screen {want} sr"
        );
        // Pixels per degree at the centre: 360 px per metre at 1 m, one degree = 17.45 mm.
        let centre = f.pixels_per_degree[(26 * 90 + 45) as usize];
        assert!(
            (centre - 360.0 * 1f32.to_radians().tan()).abs() < 0.05,
            "{centre}"
        );
        // Half the pixels: 45 rows (four pixels a sample at least), still 90 columns.
        let half = |p: Vec2| dirs(p * 2.0);
        let g = Fovea::new(w / 2, h / 2, &half);
        assert_eq!((g.cols, g.rows), (90, 45));
    }
}
