//! Ray queries over the scene's triangles: a compressed-wide BVH (CWBVH) from `obvhs`.
//!
//! Two pitfalls of obvhs 0.4 are handled here, each with a test below:
//! - its traversal misses every hit when a direction component is `-0.0`, so every
//!   direction gets `+ 0.0` (which turns `-0.0` into `+0.0`) before traversal;
//! - its `Triangle::compute_barycentric` is scaled by the triangle's area, so the
//!   intersection (and its barycentrics) is computed here, by Möller–Trumbore.
//!
//! Möller–Trumbore in `f32` is not watertight: a ray through the edge two triangles share
//! can get a barycentric of −1e-7 in both and slip through a closed surface. The bounds
//! are therefore widened by [`EDGE_TOLERANCE`] (far above the rounding error, far below
//! anything visible) and the barycentrics clamped back into the triangle.

use std::time::{Duration, Instant};

use glam::{Vec3, Vec3A};
use obvhs::{
    BvhBuildParams,
    cwbvh::{CwBvh, builder::build_cwbvh_from_tris},
    ray::RayHit,
    triangle::Triangle,
};

use crate::ray::{Hit, Ray};

/// How far outside `[0, 1]` a barycentric may fall and still hit: 50 times the rounding
/// error seen on shared edges, i.e. 10 µm on a 1 m triangle.
pub const EDGE_TOLERANCE: f32 = 1e-5;

/// A triangle prepared for intersection: first vertex and the two edges from it.
#[derive(Clone, Copy, Debug)]
struct IsectTriangle {
    v0: Vec3A,
    e1: Vec3A,
    e2: Vec3A,
}

impl IsectTriangle {
    /// Möller–Trumbore. Returns `(t, u, v)`; `t` is infinite on a miss. Written so that
    /// any NaN along the way is a miss.
    #[inline(always)]
    fn intersect(&self, ray: &obvhs::ray::Ray) -> (f32, f32, f32) {
        const MISS: (f32, f32, f32) = (f32::INFINITY, 0.0, 0.0);
        let p = ray.direction.cross(self.e2);
        let det = self.e1.dot(p);
        if det == 0.0 {
            return MISS;
        }
        let inv = 1.0 / det;
        let s = ray.origin - self.v0;
        let u = s.dot(p) * inv;
        if !(-EDGE_TOLERANCE..=1.0 + EDGE_TOLERANCE).contains(&u) {
            return MISS;
        }
        let q = s.cross(self.e1);
        let v = ray.direction.dot(q) * inv;
        if !(v >= -EDGE_TOLERANCE && u + v <= 1.0 + EDGE_TOLERANCE) {
            return MISS;
        }
        let t = self.e2.dot(q) * inv;
        if !(t >= ray.tmin && t < ray.tmax) {
            return MISS;
        }
        // Back inside the triangle, for interpolation.
        let (u, v) = (u.max(0.0), v.max(0.0));
        let over = (u + v - 1.0).max(0.0) * 0.5;
        (t, (u - over).max(0.0), (v - over).max(0.0))
    }
}

/// The BVH and its triangles, stored in the BVH's leaf order.
pub struct Bvh {
    bvh: CwBvh,
    /// Triangles in leaf order (a triangle may appear more than once with spatial splits).
    triangles: Vec<IsectTriangle>,
    /// For each leaf-order slot, the caller's triangle index.
    original: Vec<u32>,
    build_time: Duration,
}

impl Bvh {
    /// Builds the BVH over triangles given as three vertices each.
    pub fn build(vertices: &[[Vec3; 3]]) -> Self {
        let start = Instant::now();
        let tris: Vec<Triangle> = vertices
            .iter()
            .map(|t| Triangle {
                v0: t[0].into(),
                v1: t[1].into(),
                v2: t[2].into(),
            })
            .collect();
        let mut core = Duration::ZERO;
        let bvh = build_cwbvh_from_tris(&tris, BvhBuildParams::medium_build(), &mut core);
        let original = bvh.primitive_indices.clone();
        let triangles = original
            .iter()
            .map(|&i| {
                let t = &tris[i as usize];
                IsectTriangle {
                    v0: t.v0,
                    e1: t.v1 - t.v0,
                    e2: t.v2 - t.v0,
                }
            })
            .collect();
        Self {
            bvh,
            triangles,
            original,
            build_time: start.elapsed(),
        }
    }

    /// Wall-clock time the build took.
    pub fn build_time(&self) -> Duration {
        self.build_time
    }

    /// Converts to obvhs' ray, or `None` for a ray that cannot hit anything (non-finite
    /// or zero direction).
    fn to_obvhs(ray: &Ray, tmax: f32) -> Option<obvhs::ray::Ray> {
        // `+ 0.0` turns -0.0 into +0.0: obvhs' traversal misses everything otherwise.
        let dir = ray.dir + Vec3::ZERO;
        if !ray.origin.is_finite() || !dir.is_finite() || dir == Vec3::ZERO || tmax.is_nan() {
            return None;
        }
        Some(obvhs::ray::Ray::new(
            ray.origin.into(),
            dir.into(),
            0.0,
            tmax,
        ))
    }

    /// The closest hit with `t < tmax`, if any.
    pub fn closest_hit(&self, ray: &Ray, tmax: f32) -> Option<Hit> {
        let r = Self::to_obvhs(ray, tmax)?;
        let mut hit = RayHit::none();
        let (mut u, mut v) = (0.0, 0.0);
        let found = self.bvh.ray_traverse(r, &mut hit, |r, id| {
            let (t, tu, tv) = self.triangles[id].intersect(r);
            if t < r.tmax {
                u = tu;
                v = tv;
            }
            t
        });
        found.then(|| Hit {
            triangle: self.original[hit.primitive_id as usize],
            t: hit.t,
            u,
            v,
        })
    }

    /// True when something lies on the ray before `tmax`.
    pub fn occluded(&self, ray: &Ray, tmax: f32) -> bool {
        match Self::to_obvhs(ray, tmax) {
            Some(r) => !self
                .bvh
                .ray_traverse_miss(r, |r, id| self.triangles[id].intersect(r).0),
            None => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> Vec<[Vec3; 3]> {
        // A unit square in the z = 0 plane made of two triangles sharing the diagonal.
        let (a, b, c, d) = (
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        );
        vec![[a, b, c], [a, c, d]]
    }

    #[test]
    fn negative_zero_direction_components_still_hit() {
        let bvh = Bvh::build(&quad());
        let ray = Ray::new(Vec3::new(0.25, 0.6, 1.0), Vec3::new(-0.0, -0.0, -1.0));
        let hit = bvh.closest_hit(&ray, f32::INFINITY).expect("ray must hit");
        assert!((hit.t - 1.0).abs() < 1e-6);
        assert!(bvh.occluded(&ray, f32::INFINITY));
    }

    #[test]
    fn rays_through_a_shared_edge_hit_one_of_its_triangles() {
        // The quad's diagonal from (0,0) to (1,1), aimed at from scattered origins: plain
        // f32 Möller–Trumbore lets some of these through both triangles.
        let bvh = Bvh::build(&quad());
        let mut missed = 0;
        for i in 0..20_000u32 {
            let f = (i as f32 + 0.5) / 20_000.0;
            let target = Vec3::new(f, f, 0.0);
            let k = i as f32 * 0.618_034;
            let o = Vec3::new(3.0 * k.sin(), 3.0 * (1.7 * k).cos(), 2.0 + k.fract());
            let ray = Ray::new(o, (target - o).normalize());
            match bvh.closest_hit(&ray, f32::INFINITY) {
                Some(h) => {
                    assert!(h.u >= 0.0 && h.v >= 0.0 && h.u + h.v <= 1.0, "{h:?}");
                }
                None => missed += 1,
            }
        }
        assert_eq!(missed, 0, "rays slipped between the two triangles");
    }

    #[test]
    fn barycentrics_are_not_area_scaled() {
        // A large triangle (area 50): obvhs' own barycentrics would be off by that factor.
        let (a, b, c) = (
            Vec3::ZERO,
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(0.0, 10.0, 0.0),
        );
        let bvh = Bvh::build(&[[a, b, c]]);
        let target = Vec3::new(2.0, 3.0, 0.0);
        let ray = Ray::new(target + Vec3::Z, -Vec3::Z);
        let hit = bvh.closest_hit(&ray, f32::INFINITY).unwrap();
        let p = a * (1.0 - hit.u - hit.v) + b * hit.u + c * hit.v;
        assert!((p - target).length() < 1e-5, "{p} != {target}");
    }

    #[test]
    fn closest_of_several_and_tmax_respected() {
        let mut tris = quad();
        for t in quad() {
            tris.push(t.map(|p| p + Vec3::new(0.0, 0.0, -2.0)));
        }
        let bvh = Bvh::build(&tris);
        let ray = Ray::new(Vec3::new(0.3, 0.2, 1.0), -Vec3::Z);
        let hit = bvh.closest_hit(&ray, f32::INFINITY).unwrap();
        assert!((hit.t - 1.0).abs() < 1e-6);
        assert!(hit.triangle < 2);
        assert!(bvh.closest_hit(&ray, 0.5).is_none());
        assert!(!bvh.occluded(&ray, 0.999));
        assert!(bvh.occluded(&ray, 1.001));
    }

    #[test]
    fn bad_rays_hit_nothing() {
        let bvh = Bvh::build(&quad());
        for dir in [Vec3::ZERO, Vec3::new(f32::NAN, 0.0, -1.0), Vec3::INFINITY] {
            let ray = Ray::new(Vec3::new(0.5, 0.5, 1.0), dir);
            assert!(bvh.closest_hit(&ray, f32::INFINITY).is_none());
            assert!(!bvh.occluded(&ray, f32::INFINITY));
        }
    }
}
