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

    /// The ray leaving surface point `p` (face normal `ng`) along `dir`, started
    /// [`surface_epsilon`] off the surface on the side `dir` points to, so that it does
    /// not meet the surface it leaves.
    pub fn leaving(p: Vec3, ng: Vec3, dir: Vec3) -> Self {
        Self::new(leave_surface(p, ng, dir), dir)
    }
}

/// How far off a surface a new ray starts, and short of a surface a segment to it stops,
/// at point `p`: 1e-4 of the coordinates' magnitude up to 100 m from the origin (at most
/// 10 mm), far above both the float spacing there and the triangle test's rounding; and
/// farther out four float steps of the coordinates (`4 ε |p|`), because a hit point is
/// only known to about one step of its coordinates (off its plane by up to √3/2 of one,
/// and the offset point rounded again), while a relative 1e-4 would there skip past
/// whole objects (10 m at 100 km from the origin).
pub fn surface_epsilon(p: Vec3) -> f32 {
    let magnitude = p.abs().max_element();
    (1e-4 * (1.0 + magnitude.min(100.0))).max(4.0 * f32::EPSILON * magnitude)
}

/// Surface point `p` moved [`surface_epsilon`] along its face normal `ng`, to the side
/// `towards` points to.
pub fn leave_surface(p: Vec3, ng: Vec3, towards: Vec3) -> Vec3 {
    p + ng * (surface_epsilon(p) * ng.dot(towards).signum())
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ray_leaves_its_surface_by_more_than_float_spacing_and_no_more_than_needed() {
        // Points on a tilted plane through p at magnitudes from 1 mm to 1000 km: the
        // offset start, as rounded to f32, lies at least two float steps of the
        // coordinates off the plane (p itself is off it by at most one), and no farther
        // than 10 mm or eight steps.
        let n = Vec3::new(0.48, 0.6, 0.64);
        for k in -3..=6 {
            let m = 10f32.powi(k);
            for p in [Vec3::new(m, 0.3 * m, -0.7 * m), Vec3::new(-m, m, 0.1 * m)] {
                let step = f32::EPSILON * m; // one float step at magnitude m, to a factor 2
                let height = (leave_surface(p, n, n) - p).dot(n);
                assert!(height >= 2.0 * step, "{p}: {height} above, step {step}");
                assert!(height <= (8.0 * step).max(0.0101), "{p}: {height} above");
                let below = (leave_surface(p, n, -n) - p).dot(n);
                assert!(below <= -2.0 * step, "{p}: {below}");
            }
        }
    }
}
