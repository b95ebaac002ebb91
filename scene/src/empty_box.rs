//! An empty box around a point: the axis-aligned region a holodeck's interior section may
//! fill. Such a section only holds rays passing through it, so no surface may lie inside
//! it (a table inside a CAVE would vanish); it is cut down from a starting box until every
//! triangle lies outside, keeping the point (where the viewer's eyes are) inside.

use glam::DVec3;

use crate::Scene;

/// An axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub lo: DVec3,
    pub hi: DVec3,
}

impl Aabb {
    pub fn volume(&self) -> f64 {
        (self.hi - self.lo).max(DVec3::ZERO).element_product()
    }
}

/// Shrinks `start` until no triangle of `scene` comes within `gap` of it, keeping `keep`
/// at least `gap` inside. Each triangle that reaches into the box is cut off by moving the
/// one face that keeps the most volume; the box only shrinks, so one pass over the
/// triangles suffices. `None` when a triangle passes within `gap` of `keep` itself.
pub fn empty_box(scene: &Scene, start: Aabb, keep: DVec3, gap: f64) -> Option<Aabb> {
    let mut b = start;
    for i in 0..scene.triangle_count() as u32 {
        let tri = scene.triangle(i).map(|p| p.as_dvec3());
        let grown = Aabb {
            lo: b.lo - gap,
            hi: b.hi + gap,
        };
        let Some(part) = clip_bounds(&tri, &grown) else {
            continue;
        };
        let mut best: Option<Aabb> = None;
        for a in 0..3 {
            let mut above = b;
            above.lo[a] = part.hi[a] + gap;
            let mut below = b;
            below.hi[a] = part.lo[a] - gap;
            for cut in [above, below] {
                let keeps = (keep - cut.lo).cmpge(DVec3::splat(gap)).all()
                    && (cut.hi - keep).cmpge(DVec3::splat(gap)).all();
                if keeps && best.is_none_or(|x| cut.volume() > x.volume()) {
                    best = Some(cut);
                }
            }
        }
        b = best?;
    }
    Some(b)
}

/// How many triangles of `scene` reach into the open box `b` (exactly: each triangle is
/// clipped against the box shrunk by a `gap` of 1 µm, so one lying on a face is outside).
pub fn triangles_inside(scene: &Scene, b: &Aabb) -> usize {
    const ON_FACE: f64 = 1e-6;
    let shrunk = Aabb {
        lo: b.lo + ON_FACE,
        hi: b.hi - ON_FACE,
    };
    (0..scene.triangle_count() as u32)
        .filter(|&i| clip_bounds(&scene.triangle(i).map(|p| p.as_dvec3()), &shrunk).is_some())
        .count()
}

/// The bounds of the part of triangle `tri` inside `b` (closed), if any: the triangle
/// clipped against each face's plane in turn (Sutherland–Hodgman).
fn clip_bounds(tri: &[DVec3; 3], b: &Aabb) -> Option<Aabb> {
    let mut poly: Vec<DVec3> = tri.to_vec();
    for a in 0..3 {
        for (bound, keep_below) in [(b.lo[a], false), (b.hi[a], true)] {
            let inside = |p: &DVec3| {
                if keep_below {
                    p[a] <= bound
                } else {
                    p[a] >= bound
                }
            };
            let mut out = Vec::with_capacity(poly.len() + 2);
            for (k, p) in poly.iter().enumerate() {
                let q = poly[(k + 1) % poly.len()];
                match (inside(p), inside(&q)) {
                    (true, true) => out.push(*p),
                    (true, false) => {
                        out.push(*p);
                        out.push(crossing(*p, q, a, bound));
                    }
                    (false, true) => out.push(crossing(*p, q, a, bound)),
                    (false, false) => {}
                }
            }
            poly = out;
            if poly.is_empty() {
                return None;
            }
        }
    }
    let lo = poly.iter().fold(DVec3::INFINITY, |m, p| m.min(*p));
    let hi = poly.iter().fold(DVec3::NEG_INFINITY, |m, p| m.max(*p));
    Some(Aabb { lo, hi })
}

/// Where the segment p→q crosses the plane `axis = bound` (p and q on either side).
fn crossing(p: DVec3, q: DVec3, axis: usize, bound: f64) -> DVec3 {
    let t = (bound - p[axis]) / (q[axis] - p[axis]);
    let mut x = p + (q - p) * t;
    x[axis] = bound;
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::LoadOptions;

    fn load(name: &str) -> Scene {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../scenes")
            .join(name);
        Scene::load(&path, &LoadOptions::default()).unwrap()
    }

    fn unit_room() -> Aabb {
        Aabb {
            lo: DVec3::new(-1.5, 0.0, -1.5),
            hi: DVec3::new(1.5, 3.0, 1.5),
        }
    }

    /// True when no triangle comes within `gap` (less rounding) of the box.
    fn clear(scene: &Scene, b: &Aabb, gap: f64) -> bool {
        let g = Aabb {
            lo: b.lo - gap * 0.999,
            hi: b.hi + gap * 0.999,
        };
        (0..scene.triangle_count() as u32)
            .all(|i| clip_bounds(&scene.triangle(i).map(|p| p.as_dvec3()), &g).is_none())
    }

    #[test]
    fn a_cave_in_the_room_scene_is_cut_above_its_table_and_below_its_lamp() {
        // The 3 m CAVE of configs/cave4-room.toml standing in scenes/room.gltf: the floor
        // and ceiling are its faces, a table (top at 0.76 m) and a block (0.8 m high)
        // stand inside it and a ceiling lamp hangs at 2.99 m.
        let scene = load("room.gltf");
        let start = unit_room();
        assert!(
            !clear(&scene, &start, 0.01),
            "the CAVE's box holds the table"
        );
        let head = DVec3::new(0.0, 1.5, 0.0);
        let b = empty_box(&scene, start, head, 0.01).expect("the head's space is empty");
        assert!(clear(&scene, &b, 0.01), "{b:?}");
        assert!((head - b.lo).min_element() >= 0.01 && (b.hi - head).min_element() >= 0.01);
        // Only the height is cut: above the block (0.8 m) and below the lamp (2.99 m).
        let expect_lo = DVec3::new(-1.5, 0.81, -1.5);
        let expect_hi = DVec3::new(1.5, 2.98, 1.5);
        assert!((b.lo - expect_lo).abs().max_element() < 1e-5, "{b:?}");
        assert!((b.hi - expect_hi).abs().max_element() < 1e-5, "{b:?}");
    }

    #[test]
    fn a_surface_through_the_eye_leaves_no_box() {
        let scene = load("cornell.gltf");
        let (lo, hi) = scene.bounds();
        let start = Aabb {
            lo: lo.as_dvec3() - 1.0,
            hi: hi.as_dvec3() + 1.0,
        };
        // A point on the box's floor cannot be kept a gap away from it.
        let on_floor = DVec3::new(
            (lo.x + hi.x) as f64 * 0.5,
            lo.y as f64,
            (lo.z + hi.z) as f64 * 0.5,
        );
        assert_eq!(empty_box(&scene, start, on_floor, 0.01), None);
    }

    #[test]
    fn clipping_finds_the_part_inside() {
        let tri = [
            DVec3::new(-2.0, 1.0, 0.0),
            DVec3::new(2.0, 1.0, 0.0),
            DVec3::new(0.0, 5.0, 0.0),
        ];
        let b = clip_bounds(&tri, &unit_room()).unwrap();
        assert!(
            (b.lo - DVec3::new(-1.5, 1.0, 0.0)).length() < 1e-12,
            "{b:?}"
        );
        assert!((b.hi - DVec3::new(1.5, 3.0, 0.0)).length() < 1e-12, "{b:?}");
        let far = tri.map(|p| p + DVec3::X * 10.0);
        assert_eq!(clip_bounds(&far, &unit_room()), None);
    }
}
