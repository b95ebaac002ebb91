//! The irradiance atlas: every triangle's two sides cut into elements.
//!
//! A triangle with resolution `r` is cut along its barycentric coordinates `(u, v)` into
//! the `r(r+1)/2` cells of an `r × r` grid that lie in it: cell `(i, j)` holds the points
//! with `⌊u·r⌋ = i`, `⌊v·r⌋ = j`; the `r` cells on the diagonal (`i + j = r − 1`) are half
//! squares. `r` is the triangle's longest edge over the element size (at least 1, at
//! most [`MAX_RESOLUTION`]), so an element is about one element size across along the
//! triangle's edges. Each side has its own elements (opaque surfaces reflect on both
//! sides, and a thin wall lit on one side must stay dark on the other): the front side's
//! cells come first, then the back's. The layout depends only on the scene and the
//! element size, so a file stores the irradiance and not the layout.

use glam::Vec3;
use holocave_scene::Scene;

/// The most cells along a triangle's edge.
pub const MAX_RESOLUTION: u32 = 1024;

/// Where one triangle's elements are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TriangleCells {
    /// First element of the front side; the back side follows after `cells(res)`.
    pub offset: u32,
    pub res: u32,
}

/// The element layout of a scene.
#[derive(Clone, Debug)]
pub struct Elements {
    pub triangles: Vec<TriangleCells>,
    pub count: usize,
    pub element_size: f32,
}

/// Cells of a triangle with resolution `r`.
pub fn cells(r: u32) -> u32 {
    r * (r + 1) / 2
}

/// The cell `(i, j)` of a triangle with resolution `r`, clamped into the triangle.
pub fn cell_index(i: u32, j: u32, r: u32) -> u32 {
    let i = i.min(r - 1);
    let j = j.min(r - 1 - i);
    j * r - j * j.saturating_sub(1) / 2 + i
}

/// The cell holding barycentric `(u, v)`.
pub fn cell_at(u: f32, v: f32, r: u32) -> u32 {
    let rf = r as f32;
    cell_index((u * rf).max(0.0) as u32, (v * rf).max(0.0) as u32, r)
}

/// The value at barycentric `(u, v)` interpolated bilinearly between the four nearest
/// cell centres of one side (`base` = its first element). The render node's shader
/// (`render-node/src/cache/shade_field.wgsl`) does the same.
pub fn interpolate(values: &[[f32; 3]], base: u32, r: u32, u: f32, v: f32) -> Vec3 {
    let ([c00, c10, c01, c11], fx, fy) = corners(r, u, v);
    let at = |c: u32| Vec3::from(values[(base + c) as usize]);
    let bottom = at(c00) * (1.0 - fx) + at(c10) * fx;
    let top = at(c01) * (1.0 - fx) + at(c11) * fx;
    bottom * (1.0 - fy) + top * fy
}

/// The four cells [`interpolate`] reads at barycentric `(u, v)` and their weights (a
/// cell may appear twice at the triangle's edges).
pub fn bilinear_cells(base: u32, r: u32, u: f32, v: f32) -> [(u32, f32); 4] {
    let ([c00, c10, c01, c11], fx, fy) = corners(r, u, v);
    [
        (base + c00, (1.0 - fx) * (1.0 - fy)),
        (base + c10, fx * (1.0 - fy)),
        (base + c01, (1.0 - fx) * fy),
        (base + c11, fx * fy),
    ]
}

/// The cells at the four cell centres nearest barycentric `(u, v)` (bottom left and
/// right, top left and right), and where `(u, v)` lies between them.
fn corners(r: u32, u: f32, v: f32) -> ([u32; 4], f32, f32) {
    let rf = r as f32;
    let (x, y) = ((u * rf - 0.5).max(0.0), (v * rf - 0.5).max(0.0));
    let (i0, j0) = ((x as u32).min(r - 1), (y as u32).min(r - 1));
    let (i1, j1) = ((i0 + 1).min(r - 1), (j0 + 1).min(r - 1));
    let (fx, fy) = (
        (x - i0 as f32).clamp(0.0, 1.0),
        (y - j0 as f32).clamp(0.0, 1.0),
    );
    let cells = [(i0, j0), (i1, j0), (i0, j1), (i1, j1)].map(|(i, j)| cell_index(i, j, r));
    (cells, fx, fy)
}

impl TriangleCells {
    /// The first element of `side` (0 front, 1 back).
    pub fn base(&self, side: u32) -> u32 {
        self.offset + side * cells(self.res)
    }
}

impl Elements {
    /// The layout for elements about `element_size` across.
    pub fn new(scene: &Scene, element_size: f32) -> Elements {
        let mut triangles = Vec::with_capacity(scene.triangle_count());
        let mut count = 0usize;
        for t in 0..scene.triangle_count() as u32 {
            let [a, b, c] = *scene.triangle(t);
            let longest = (b - a).length().max((c - b).length()).max((a - c).length());
            let res = ((longest / element_size).ceil() as u32).clamp(1, MAX_RESOLUTION);
            triangles.push(TriangleCells {
                offset: count as u32,
                res,
            });
            count += 2 * cells(res) as usize;
        }
        Elements {
            triangles,
            count,
            element_size,
        }
    }

    /// The element of `side` of triangle `t` at barycentric `(u, v)`.
    pub fn element(&self, t: u32, side: u32, u: f32, v: f32) -> u32 {
        let c = self.triangles[t as usize];
        c.base(side) + cell_at(u, v, c.res)
    }

    /// The area of every element (both sides), and a barycentric point inside each (the
    /// cell's centroid).
    pub fn areas_and_centres(&self, scene: &Scene) -> (Vec<f32>, Vec<(u32, f32, f32)>) {
        let mut area = vec![0f32; self.count];
        let mut centre = vec![(0u32, 0f32, 0f32); self.count];
        for (t, c) in self.triangles.iter().enumerate() {
            let a = scene.triangle_area(t as u32);
            let r = c.res;
            let rf = r as f32;
            for j in 0..r {
                for i in 0..r - j {
                    let diagonal = i + j == r - 1;
                    let (ea, (cu, cv)) = if diagonal {
                        (
                            a / (rf * rf),
                            ((i as f32 + 1.0 / 3.0) / rf, (j as f32 + 1.0 / 3.0) / rf),
                        )
                    } else {
                        (
                            2.0 * a / (rf * rf),
                            ((i as f32 + 0.5) / rf, (j as f32 + 0.5) / rf),
                        )
                    };
                    for side in 0..2 {
                        let e = (c.base(side) + cell_index(i, j, r)) as usize;
                        area[e] = ea;
                        centre[e] = (t as u32, cu, cv);
                    }
                }
            }
        }
        (area, centre)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_cover_the_triangle_once() {
        for r in 1..12 {
            let mut seen = vec![0u32; cells(r) as usize];
            for j in 0..r {
                for i in 0..r - j {
                    seen[cell_index(i, j, r) as usize] += 1;
                }
            }
            assert!(seen.iter().all(|&n| n == 1), "r {r}: {seen:?}");
            // Points inside the triangle land in the cell that holds them.
            for k in 0..200 {
                let u = (k as f32 * 0.618_034).fract();
                let v = (k as f32 * 0.414_214).fract() * (1.0 - u);
                let c = cell_at(u, v, r);
                assert!(c < cells(r));
                let (i, j) = ((u * r as f32) as u32, (v * r as f32) as u32);
                if i + j < r {
                    assert_eq!(c, cell_index(i, j, r));
                }
            }
        }
    }

    #[test]
    fn interpolation_is_exact_at_centres_and_for_linear_values() {
        let r = 6;
        // A value linear in (u, v) is reproduced between full-cell centres.
        let mut values = vec![[0f32; 3]; cells(r) as usize];
        for j in 0..r {
            for i in 0..r - j {
                let (u, v) = ((i as f32 + 0.5) / r as f32, (j as f32 + 0.5) / r as f32);
                values[cell_index(i, j, r) as usize] = [u, v, 2.0 * u + 3.0 * v];
            }
        }
        for (u, v) in [(0.25, 0.25), (0.1, 0.4), (0.3, 0.2)] {
            let got = interpolate(&values, 0, r, u, v);
            assert!(
                (got - Vec3::new(u, v, 2.0 * u + 3.0 * v)).length() < 1e-5,
                "{got}"
            );
        }
    }
}
