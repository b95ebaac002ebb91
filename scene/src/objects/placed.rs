//! A scene with its movable objects placed for one frame: the ray queries of a render
//! node, which must see the objects where they stand now, without rebuilding anything.

use glam::Vec3;

use super::{MovableObject, Placement};
use crate::ray::{Hit, Ray};
use crate::scene::{Scene, SurfacePoint, surface_point};

/// A scene with one [`Placement`] per movable object.
pub struct PlacedScene<'a> {
    scene: &'a Scene,
    placements: &'a [Placement],
}

impl Scene {
    /// The scene with its objects at `placements`, one per object in
    /// [`Scene::objects`] order.
    ///
    /// # Panics
    /// When `placements` does not hold exactly one placement per object.
    pub fn placed<'a>(&'a self, placements: &'a [Placement]) -> PlacedScene<'a> {
        assert_eq!(
            placements.len(),
            self.objects.len(),
            "Scene::placed: one placement per movable object"
        );
        PlacedScene {
            scene: self,
            placements,
        }
    }
}

impl Scene {
    /// The static scene alone, as a [`PlacedScene`] that sees no object: what the caches
    /// (the light field, the holodeck) are made of.
    pub fn statics(&self) -> PlacedScene<'_> {
        PlacedScene {
            scene: self,
            placements: &[],
        }
    }
}

/// `ray` in the frame of an object placed at `at`: the same distances along it.
fn local_ray(ray: &Ray, at: &Placement) -> Ray {
    Ray::new(at.to_local_point(ray.origin), at.to_local_dir(ray.dir))
}

/// Whether `ray` may meet the box `(lo, hi)` before `tmax`. Errs on the side of yes:
/// the box is padded by a millionth of its size, far above the rounding of the test.
fn may_hit_box(ray: &Ray, (lo, hi): (Vec3, Vec3), tmax: f32) -> bool {
    let pad = (hi - lo).max_element() * 1e-6 + f32::EPSILON * lo.abs().max(hi.abs()).max_element();
    let (lo, hi) = (lo - pad, hi + pad);
    let (mut near, mut far) = (0.0f32, tmax);
    for a in 0..3 {
        let (o, d) = (ray.origin[a], ray.dir[a]);
        if d == 0.0 {
            if o < lo[a] || o > hi[a] {
                return false;
            }
            continue;
        }
        let (t0, t1) = ((lo[a] - o) / d, (hi[a] - o) / d);
        near = near.max(t0.min(t1));
        far = far.min(t0.max(t1));
    }
    // NaN (a non-finite ray) compares false: not culled, the BVH refuses it.
    near.partial_cmp(&far) != Some(std::cmp::Ordering::Greater)
}

impl PlacedScene<'_> {
    /// The closest hit before `tmax` among object `k`'s triangles.
    fn object_hit(&self, k: usize, ray: &Ray, tmax: f32) -> Option<Hit> {
        let o = &self.scene.objects[k];
        let local = local_ray(ray, &self.placements[k]);
        if !may_hit_box(&local, o.bounds, tmax) {
            return None;
        }
        o.bvh.closest_hit(&local, tmax).map(|h| Hit {
            triangle: o.first + h.triangle,
            ..h
        })
    }

    /// The scene queried (its static part and its objects).
    pub fn scene(&self) -> &Scene {
        self.scene
    }

    /// Where each object stands (empty for [`Scene::statics`]).
    pub fn placements(&self) -> &[Placement] {
        self.placements
    }

    /// The closest hit among the objects before `tmax`, or `best` (a hit found
    /// elsewhere, e.g. the static scene's on a GPU) where that is closer.
    pub fn objects_closest_hit(&self, ray: &Ray, tmax: f32, best: Option<Hit>) -> Option<Hit> {
        self.objects_hit(ray, tmax, best)
    }

    /// Whether an object (not the static scene) lies on the ray before `tmax`.
    pub fn objects_occluded(&self, ray: &Ray, tmax: f32) -> bool {
        self.scene
            .objects
            .iter()
            .zip(self.placements)
            .any(|(o, at)| {
                let local = local_ray(ray, at);
                may_hit_box(&local, o.bounds, tmax) && o.bvh.occluded(&local, tmax)
            })
    }

    /// The closest hit among the objects, before `tmax` and closer than `best`.
    fn objects_hit(&self, ray: &Ray, tmax: f32, mut best: Option<Hit>) -> Option<Hit> {
        for k in 0..self.placements.len() {
            let limit = best.map_or(tmax, |h| h.t);
            if let Some(h) = self.object_hit(k, ray, limit) {
                best = Some(h);
            }
        }
        best
    }

    /// The closest hit before `tmax`, static or on an object where it stands.
    pub fn closest_hit(&self, ray: &Ray, tmax: f32) -> Option<Hit> {
        self.objects_hit(ray, tmax, self.scene.bvh.closest_hit(ray, tmax))
    }

    /// The closest hit before `tmax` of each ray (the static part traced in packets, as
    /// [`Scene::closest_hits`]; give rays in a coherent order).
    pub fn closest_hits(&self, rays: &[Ray], tmax: f32) -> Vec<Option<Hit>> {
        let mut hits = self.scene.bvh.closest_hits(rays, tmax);
        for (ray, hit) in rays.iter().zip(&mut hits) {
            *hit = self.objects_hit(ray, tmax, *hit);
        }
        hits
    }

    /// Whether anything, static or placed, lies on the ray before `tmax`.
    pub fn occluded(&self, ray: &Ray, tmax: f32) -> bool {
        self.scene.bvh.occluded(ray, tmax) || self.objects_occluded(ray, tmax)
    }

    /// The object triangle `triangle` belongs to; `None` for a static triangle.
    pub fn object_of(&self, triangle: u32) -> Option<usize> {
        let objects = &self.scene.objects;
        let k = objects.partition_point(|o| o.first <= triangle);
        (k > 0 && triangle - objects[k - 1].first < objects[k - 1].positions.len() as u32)
            .then(|| k - 1)
    }

    /// The world-space surface point of a hit.
    pub fn surface(&self, hit: &Hit) -> SurfacePoint {
        let Some(k) = self.object_of(hit.triangle) else {
            return self.scene.surface(hit);
        };
        let o: &MovableObject = &self.scene.objects[k];
        let at = &self.placements[k];
        let j = (hit.triangle - o.first) as usize;
        let s = surface_point(&o.positions[j], &o.shading[j], o.faces[j], hit);
        SurfacePoint {
            position: at.to_world_point(s.position),
            geometric_normal: at.to_world_dir(s.geometric_normal),
            shading_normal: at.to_world_dir(s.shading_normal),
            ..s
        }
    }

    /// World-space axis-aligned bounds of object `k` where it stands.
    pub fn object_bounds(&self, k: usize) -> (Vec3, Vec3) {
        let (lo, hi) = self.scene.objects[k].bounds;
        let at = &self.placements[k];
        let mut out = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for c in 0..8 {
            let corner = Vec3::new(
                if c & 1 == 0 { lo.x } else { hi.x },
                if c & 2 == 0 { lo.y } else { hi.y },
                if c & 4 == 0 { lo.z } else { hi.z },
            );
            let p = at.to_world_point(corner);
            out = (out.0.min(p), out.1.max(p));
        }
        out
    }
}
