//! The BVH's queries against brute force over every triangle, and the packet query
//! against the single-ray one.
//!
//! The reference intersects in `f64`. The BVH works in `f32` with a widened triangle
//! (`EDGE_TOLERANCE`), so the comparison allows what that can change: a hit within 1e-3 of
//! a triangle's edge may go either way, and distances agree to 1e-4 relative (f32 rounding
//! over scenes of a few metres is ~1e-7 relative; the margin leaves room for grazing rays).

use glam::{DVec3, Vec3};
use holocave_scene::Ray;
use holocave_scene::bvh::{Bvh, PACKET};

/// A small deterministic generator (SplitMix64), so that a failure replays exactly.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next()
    }
    fn vec(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
    fn dir(&mut self) -> Vec3 {
        loop {
            let v = self.vec(-1.0, 1.0);
            if v.length_squared() > 0.01 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }
}

/// Triangles of many sizes, some long and thin, in a 10 m box.
fn soup(rng: &mut Rng, n: usize) -> Vec<[Vec3; 3]> {
    (0..n)
        .map(|_| {
            let c = rng.vec(-5.0, 5.0);
            let size = 0.02 * 100f32.powf(rng.next());
            let a = c + rng.dir() * size;
            let b = c + rng.dir() * size * rng.range(0.05, 1.0);
            [c, a, b]
        })
        .collect()
}

/// `(t, u, v)` of the ray and triangle in f64, with the barycentrics unclamped.
fn reference(tri: &[Vec3; 3], ray: &Ray) -> Option<(f64, f64, f64)> {
    let [v0, v1, v2] = tri.map(|p| p.as_dvec3());
    let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
    let (e1, e2) = (v1 - v0, v2 - v0);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-300 {
        return None;
    }
    let s = o - v0;
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    let t = e2.dot(q) / det;
    (t > 0.0).then_some((t, u, v))
}

/// The nearest reference hit whose barycentrics lie at least `margin` inside the triangle
/// (a negative margin lets points just outside count).
fn nearest(tris: &[[Vec3; 3]], ray: &Ray, tmax: f64, margin: f64) -> Option<f64> {
    tris.iter()
        .filter_map(|t| reference(t, ray))
        .filter(|&(t, u, v)| t < tmax && u >= margin && v >= margin && u + v <= 1.0 - margin)
        .map(|(t, _, _)| t)
        .min_by(f64::total_cmp)
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-4 * (1.0 + a.abs())
}

#[test]
fn closest_hits_and_occlusion_agree_with_brute_force() {
    let mut rng = Rng(7);
    let tris = soup(&mut rng, 3000);
    let bvh = Bvh::build(&tris);
    for i in 0..4000 {
        let ray = Ray::new(rng.vec(-6.0, 6.0), rng.dir());
        let tmax = if i % 3 == 0 {
            rng.range(0.5, 8.0)
        } else {
            f32::INFINITY
        };
        let hit = bvh.closest_hit(&ray, tmax);
        let sure = nearest(&tris, &ray, f64::from(tmax), 1e-3);
        let possible = nearest(&tris, &ray, f64::from(tmax), -1e-3);
        match hit {
            Some(h) => {
                let t = f64::from(h.t);
                // Nothing clearly nearer was missed, and something really is there.
                assert!(
                    sure.is_none_or(|s| t <= s * (1.0 + 1e-4)),
                    "ray {i}: {t} beyond {sure:?}"
                );
                let p = possible.expect("a hit where brute force finds nothing");
                assert!(
                    t >= p * (1.0 - 1e-4),
                    "ray {i}: {t} nearer than anything ({p})"
                );
                let (rt, _, _) = reference(&tris[h.triangle as usize], &ray).expect("hit triangle");
                assert!(close(t, rt), "ray {i}: t {t} but its triangle is at {rt}");
                let w = DVec3::new(1.0 - f64::from(h.u + h.v), f64::from(h.u), f64::from(h.v));
                assert!(w.min_element() >= 0.0, "ray {i}: barycentrics {w} outside");
            }
            None => assert!(sure.is_none(), "ray {i} missed a hit at {sure:?}"),
        }
        assert_eq!(
            bvh.occluded(&ray, tmax),
            hit.is_some(),
            "ray {i}: occlusion disagrees"
        );
    }
}

/// Bundles as a renderer or a holodeck beam makes them: sixteen rays from nearby (or the
/// same) origins in nearby directions; some bundles straddle an axis, so their rays fall
/// in several octants, and some carry rays that cannot hit anything.
fn bundles(rng: &mut Rng, count: usize) -> Vec<Ray> {
    let mut rays = Vec::new();
    for b in 0..count {
        let origin = rng.vec(-6.0, 6.0);
        let spread_origin = if b % 2 == 0 { 0.0 } else { 0.05 };
        let mut centre = rng.dir();
        if b % 5 == 0 {
            centre.x = 0.0; // straddles the x = 0 plane of directions
        }
        let spread = if b % 7 == 0 { 0.5 } else { 0.02 };
        for k in 0..PACKET {
            let mut dir = (centre + rng.vec(-spread, spread)).normalize();
            if b % 11 == 0 && k == 3 {
                dir = Vec3::new(-0.0, dir.y, -0.0).normalize();
            }
            if b % 13 == 0 && k == 5 {
                dir = Vec3::ZERO;
            }
            if b % 17 == 0 && k == 9 {
                dir = Vec3::new(f32::NAN, 0.0, 1.0);
            }
            rays.push(Ray::new(
                origin + rng.vec(-spread_origin, spread_origin),
                dir,
            ));
        }
    }
    rays
}

#[test]
fn packets_give_the_hits_single_rays_give() {
    let mut rng = Rng(11);
    let tris = soup(&mut rng, 3000);
    let bvh = Bvh::build(&tris);
    let rays = bundles(&mut rng, 600);
    for tmax in [f32::INFINITY, 3.0] {
        let packed = bvh.closest_hits(&rays, tmax);
        assert_eq!(packed.len(), rays.len());
        let mut hits = 0;
        for (i, (ray, p)) in rays.iter().zip(&packed).enumerate() {
            let s = bvh.closest_hit(ray, tmax);
            match (s, p) {
                (None, None) => {}
                (Some(s), Some(p)) => {
                    hits += 1;
                    assert!(
                        close(f64::from(s.t), f64::from(p.t)),
                        "ray {i}: {s:?} vs {p:?}"
                    );
                    // The same triangle, unless two lie at the same distance (a shared
                    // edge or vertex).
                    if s.triangle != p.triangle {
                        let other = reference(&tris[p.triangle as usize], ray).unwrap().0;
                        assert!(close(other, f64::from(s.t)), "ray {i}: {s:?} vs {p:?}");
                    } else {
                        assert!((s.u - p.u).abs() < 1e-4 && (s.v - p.v).abs() < 1e-4);
                    }
                }
                _ => panic!("ray {i} ({ray:?}): single {s:?}, packet {p:?}"),
            }
        }
        // The comparison means something only if many rays hit.
        assert!(hits >= 1000, "only {hits} of {} rays hit", rays.len());
    }
}

#[test]
fn packets_of_any_length_and_an_empty_tree() {
    let mut rng = Rng(3);
    let tris = soup(&mut rng, 200);
    let bvh = Bvh::build(&tris);
    let rays = bundles(&mut rng, 3);
    for n in [0, 1, 2, 5, PACKET + 1, rays.len()] {
        let packed = bvh.closest_hits(&rays[..n], f32::INFINITY);
        let single: Vec<_> = rays[..n]
            .iter()
            .map(|r| bvh.closest_hit(r, f32::INFINITY))
            .collect();
        assert_eq!(packed.len(), n);
        for (p, s) in packed.iter().zip(&single) {
            assert_eq!(p.map(|h| h.triangle), s.map(|h| h.triangle));
        }
    }
    let empty = Bvh::build(&[]);
    assert!(
        empty
            .closest_hits(&rays, f32::INFINITY)
            .iter()
            .all(Option::is_none)
    );
    assert!(
        rays.iter()
            .all(|r| empty.closest_hit(r, f32::INFINITY).is_none())
    );
    assert!(rays.iter().all(|r| !empty.occluded(r, f32::INFINITY)));
}
