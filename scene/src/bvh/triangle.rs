//! One triangle's ray test, by Möller–Trumbore.
//!
//! Möller–Trumbore in `f32` is not watertight: a ray through the edge two triangles share
//! can get a barycentric of −1e-7 in both and slip through a closed surface. The bounds
//! are therefore widened by [`EDGE_TOLERANCE`] (far above the rounding error, far below
//! anything visible); the BVH clamps the barycentrics of the hit it keeps back into the
//! triangle.

use glam::Vec3A;

/// How far outside `[0, 1]` a barycentric may fall and still hit: 50 times the rounding
/// error seen on shared edges, i.e. 10 µm on a 1 m triangle.
pub const EDGE_TOLERANCE: f32 = 1e-5;

/// A triangle prepared for intersection: first vertex and the two edges from it.
#[derive(Clone, Copy, Debug)]
pub(super) struct IsectTriangle {
    pub v0: Vec3A,
    pub e1: Vec3A,
    pub e2: Vec3A,
}

impl IsectTriangle {
    /// Möller–Trumbore. Returns `(t, u, v)`; `t` is infinite on a miss, and `(u, v)` may lie up to the
    /// tolerance outside the triangle. Written so that
    /// any NaN along the way is a miss.
    #[inline(always)]
    pub fn intersect(&self, origin: Vec3A, dir: Vec3A, tmax: f32) -> (f32, f32, f32) {
        const MISS: (f32, f32, f32) = (f32::INFINITY, 0.0, 0.0);
        let p = dir.cross(self.e2);
        let det = self.e1.dot(p);
        if det == 0.0 {
            return MISS;
        }
        let inv = 1.0 / det;
        let s = origin - self.v0;
        let u = s.dot(p) * inv;
        if !(-EDGE_TOLERANCE..=1.0 + EDGE_TOLERANCE).contains(&u) {
            return MISS;
        }
        let q = s.cross(self.e1);
        let v = dir.dot(q) * inv;
        if !(v >= -EDGE_TOLERANCE && u + v <= 1.0 + EDGE_TOLERANCE) {
            return MISS;
        }
        let t = self.e2.dot(q) * inv;
        if !(t >= 0.0 && t < tmax) {
            return MISS;
        }
        (t, u, v)
    }
}

impl IsectTriangle {
    /// The box around every point the widened test accepts: the triangle's box grown by
    /// the tolerance along its edges, and by a few ulps of its coordinates for rounding.
    pub fn bounds(&self) -> (Vec3A, Vec3A) {
        let (a, b, c) = (self.v0, self.v0 + self.e1, self.v0 + self.e2);
        let min = a.min(b).min(c);
        let max = a.max(b).max(c);
        let edge = self
            .e1
            .abs()
            .max(self.e2.abs())
            .max((self.e2 - self.e1).abs());
        let magnitude = min.abs().max(max.abs());
        let pad = edge * (2.0 * EDGE_TOLERANCE) + magnitude * (4.0 * f32::EPSILON);
        (min - pad, max + pad)
    }
}
