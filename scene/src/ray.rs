//! Rays and the hits of ray queries.

use glam::Vec3;

/// A ray: origin and unit direction, in scene metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
}

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self { origin, dir }
    }

    /// The point at distance `t` along the ray.
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// The closest intersection of a ray with the scene.
///
/// `u` and `v` are the barycentric weights of the triangle's second and third vertex
/// (the first has `1 - u - v`), so attributes interpolate as `a0*(1-u-v) + a1*u + a2*v`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub triangle: u32,
    pub t: f32,
    pub u: f32,
    pub v: f32,
}
